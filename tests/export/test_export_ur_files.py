"""UR calibration files: read by the reader as written by hand or by the exporter,
with the model from the file or the caller, and refused in one line when broken."""

import configparser
import json
from dataclasses import replace

import numpy as np
import pytest
from export_kit import KEYS, calibrated, poses, ur_file

from calibrator import export, robots
from calibrator.errors import CalibrationError
from calibrator.export import ur
from calibrator.model import kinematics


def test_hand_written_deltas_are_read_in_mm_and_rad(tmp_path):
    values = {
        "delta_theta": [0.001, -0.002, 0, 0, 0, 0.003],
        "delta_a": [0, 0.0005, -0.001, 0, 0, 0],
        "delta_d": [0.0002, 0, 0, 0, -0.0004, 0],
        "delta_alpha": [0, 0, 0, 0.004, 0, 0],
    }
    deltas, model = ur.read(ur_file(tmp_path, values, model="UR10"))
    assert model == "ur10"
    expected = np.zeros((6, 5))
    expected[:, kinematics.THETA] = values["delta_theta"]
    expected[:, kinematics.A] = np.array(values["delta_a"]) * 1000.0
    expected[:, kinematics.D] = np.array(values["delta_d"]) * 1000.0
    expected[:, kinematics.ALPHA] = values["delta_alpha"]
    np.testing.assert_allclose(deltas, expected, rtol=1e-15, atol=0)
    assert deltas.dtype == float


def test_the_model_comes_from_the_caller_when_the_file_has_none(tmp_path):
    path = ur_file(tmp_path, model=None)
    deltas, model = ur.read(path, "UR10e")
    assert model == "ur10e" and not deltas.any()
    with pytest.raises(CalibrationError, match="needs a UR model"):
        ur.read(path)
    # Same model in other letters is no conflict.
    assert ur.read(ur_file(tmp_path, model="UR10"), "ur10")[1] == "ur10"


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("[calibrator]\nmodel = ur10\n", "{path}: no [mounting] section with DH deltas"),
        (None, "{path}: [mounting] has no delta_d"),
        (
            "[mounting]\n"
            + "".join(f"{k} = [0, 0, 0, 0, 0, 0]\n" for k in KEYS[:3])
            + "delta_alpha = zero\n",
            "{path}: delta_alpha must be a list of six finite numbers",
        ),
        (
            "[mounting]\n"
            + "".join(f"{k} = [0, 0, 0, 0, 0, 0]\n" for k in KEYS[1:])
            + "delta_theta = [0, 0, 0, 0, true, 0]\n",
            "{path}: delta_theta must be a list of six finite numbers",
        ),
        (
            "[mounting]\n"
            + "".join(f"{k} = [0, 0, 0, 0, 0, 0]\n" for k in KEYS[1:])
            + 'delta_theta = [0, 0, 0, 0, "1", 0]\n',
            "{path}: delta_theta must be a list of six finite numbers",
        ),
    ],
)
def test_broken_files_are_refused_in_one_line(tmp_path, content, message):
    path = ur_file(tmp_path, drop=("delta_d",))
    if content is not None:
        path.write_text(content)
    with pytest.raises(CalibrationError) as info:
        ur.read(path, "ur10")
    assert str(info.value) == message.format(path=path)


def test_a_file_that_is_not_ini_names_the_parser_error(tmp_path):
    path = tmp_path / "cal.conf"
    path.write_text("delta_theta = [0, 0, 0, 0, 0, 0]\n")
    try:
        configparser.ConfigParser().read_string(path.read_text(), source=str(path))
    except configparser.Error as exc:
        first = str(exc).splitlines()[0]
    with pytest.raises(CalibrationError) as info:
        ur.read(path, "ur10")
    assert str(info.value) == f"{path}: not a UR calibration file ({first})"
    path.write_bytes(b"[mounting]\ndelta_theta = [\xff]\n")
    with pytest.raises(CalibrationError, match=r"cal\.conf: not a UR calibration file \("):
        ur.read(path, "ur10")


def test_deltas_keep_the_reference_tables_hayati_lengths(tmp_path):
    """With a reference whose d2 slides the common normal elsewhere, the MDH table
    keeps that d2 and still describes the same arm."""
    cal = calibrated("ur10e", seed=31, trailing=False)
    deltas, _ = ur.deltas_from_mdh(cal.mdh, "ur10e")
    reference = robots.get("ur10e").mdh.copy()
    reference[1, kinematics.D] = 40.0
    mdh, residual = ur.mdh_from_deltas(deltas, "ur10e", reference)
    assert mdh[1, kinematics.D] == pytest.approx(40.0, abs=1e-9)
    plain, _ = ur.mdh_from_deltas(deltas, "ur10e")
    np.testing.assert_allclose(plain, cal.mdh, atol=1e-9)
    q = poses(50, seed=4)
    got = kinematics.chain(mdh, q) @ residual
    want = kinematics.chain(cal.mdh, q)
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)


def test_export_notes_what_the_form_cannot_hold():
    cal = calibrated("ur10e", seed=32, trailing=False)
    assert export.export(cal, "ur-calibration").notes == []
    mdh = cal.mdh.copy()
    mdh[5, kinematics.BETA] = 2e-3  # standard DH has no beta6
    cal = replace(cal, mdh=mdh)
    (note,) = export.export(cal, "ur-calibration").notes
    assert note.startswith("ur-calibration cannot hold beta6: the flange is ")
    assert note.endswith(" mm and 0.002 rad")


def test_exported_file_names_its_model_and_units(tmp_path):
    cal = calibrated("ur5e", seed=33, trailing=False)
    text = export.export(cal, "ur-calibration").text
    parser = configparser.ConfigParser()
    parser.read_string(text)
    assert parser.get("calibrator", "model") == "ur5e"
    deltas, _ = ur.deltas_from_mdh(cal.mdh, "ur5e")
    for key, col, scale in (
        ("delta_theta", kinematics.THETA, 1.0),
        ("delta_a", kinematics.A, 1000.0),
        ("delta_d", kinematics.D, 1000.0),
        ("delta_alpha", kinematics.ALPHA, 1.0),
    ):
        written = np.array(json.loads(parser.get("mounting", key))) * scale
        np.testing.assert_allclose(written, deltas[:, col], rtol=1e-14, atol=1e-15)


def test_a_model_without_a_published_ur_table_is_refused():
    cal = calibrated("er10l-c10", seed=34)
    with pytest.raises(CalibrationError) as info:
        export.export(cal, "ur-calibration")
    assert str(info.value) == (
        "the UR calibration form needs a UR model (ur10, ur10e, ur5e); got 'er10l-c10'"
    )


def test_exported_angle_deltas_lie_within_plus_minus_pi(tmp_path):
    """UR's factory sets, one with a theta delta beyond 2 pi: exported back, every
    angle delta is in (-pi, pi] and the chain is unchanged."""
    from test_export_ur import SETS, write_ur_file

    from calibrator.export import factory_calibration

    for i, delta_set in enumerate(SETS):
        write_ur_file(tmp_path / "f.conf", delta_set)
        imported = factory_calibration.load(tmp_path / "f.conf")
        deltas, _ = ur.deltas_from_mdh(imported.mdh, "ur10")
        angles = deltas[:, [kinematics.THETA, kinematics.ALPHA]]
        assert np.all(angles > -np.pi) and np.all(angles <= np.pi), i
        if i == 0:  # within range already: the factory numbers come back as they were
            np.testing.assert_allclose(angles[:, 0], delta_set["theta_rad"], atol=1e-9)
            np.testing.assert_allclose(angles[:, 1], delta_set["alpha_rad"], atol=1e-9)
    assert max(abs(v) for s in SETS for v in s["theta_rad"]) > 2 * np.pi


def test_residual_notes_of_an_offset_alone():
    shift = np.eye(4)
    shift[2, 3] = 0.5
    assert ur._residual_notes(shift, "ur-calibration", "beta6") == [
        "ur-calibration cannot hold beta6: the flange is off by 0.5 mm and 0 rad"
    ]
    assert ur._residual_notes(np.eye(4), "ur-calibration", "beta6") == []
