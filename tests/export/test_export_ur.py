"""UR's own factory-calibration test data, through our import and export.

The fixture holds the numbers of ``ur_calibration``'s unit test (Apache-2.0,
see fixtures/ur/). UR's convention is computed here independently: standard
DH, ``A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i)``, with the
published table plus the factory deltas.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from calibrator import robots
from calibrator.calibration import Calibration
from calibrator.export import factory_calibration, ur
from calibrator.model import kinematics

DATA = json.loads(
    (Path(__file__).parents[2] / "fixtures" / "ur" / "ur_calibration_test_data.json").read_text()
)
SETS = DATA["factory_delta_sets"]


def ur_dh_fk(d, a, theta, alpha, q):
    """Flange position (m) of UR's DH convention, written out matrix by matrix."""
    out = []
    for row in q:
        t = np.eye(4)
        for i in range(6):
            c, s = np.cos(theta[i] + row[i]), np.sin(theta[i] + row[i])
            ca, sa = np.cos(alpha[i]), np.sin(alpha[i])
            t = t @ np.array(
                [
                    [c, -s * ca, s * sa, a[i] * c],
                    [s, c * ca, -c * sa, a[i] * s],
                    [0, sa, ca, d[i]],
                    [0, 0, 0, 1],
                ]
            )
        out.append(t)
    return np.array(out)


def nominal_ur10():
    n = DATA["ur10_nominal_dh"]
    alpha = np.array([np.pi / 2, 0, 0, np.pi / 2, -np.pi / 2, 0])
    return np.array(n["d_m"]), np.array(n["a_m"]), np.array(n["theta_rad"], float), alpha


def write_ur_file(path, delta_set):
    lines = ["[mounting]"]
    for key, name in (("delta_theta", "theta_rad"), ("delta_a", "a_m"), ("delta_d", "d_m")):
        lines.append(f"{key} = {json.dumps(delta_set[name])}")
    lines.append(f"delta_alpha = {json.dumps(delta_set['alpha_rad'])}")
    lines += ["[calibrator]", "model = ur10"]
    path.write_text("\n".join(lines) + "\n")


def random_poses(n=1000, seed=0):
    return np.random.default_rng(seed).uniform(-2 * np.pi, 2 * np.pi, (n, 6))


@pytest.mark.parametrize("index", range(len(SETS)))
def test_factory_deltas_import_reproduce_ur_chain(tmp_path, index):
    delta = SETS[index]
    write_ur_file(tmp_path / "cal.conf", delta)
    imported = factory_calibration.load(tmp_path / "cal.conf")
    d, a, theta, alpha = nominal_ur10()
    q = random_poses(seed=index)
    expected = ur_dh_fk(
        d + delta["d_m"],
        a + delta["a_m"],
        theta + delta["theta_rad"],
        alpha + delta["alpha_rad"],
        q,
    )
    ours = kinematics.chain(imported.mdh, q) @ imported.flange_offset
    np.testing.assert_allclose(ours[:, :3, 3], expected[:, :3, 3] * 1000.0, rtol=0, atol=1e-6)
    np.testing.assert_allclose(ours[:, :3, :3], expected[:, :3, :3], rtol=0, atol=1e-9)
    # Hayati form: beta where axes 2-3 and 3-4 are parallel, small deltas, no
    # huge d (the factory file has d2, d3 of hundreds of metres).
    nominal_mdh = robots.get("ur10").mdh
    assert np.all(np.abs(imported.mdh[:, kinematics.D] - nominal_mdh[:, kinematics.D]) < 10.0)
    assert max(abs(d) for d in delta["d_m"]) > 1.0 or index == 0
    np.testing.assert_allclose(imported.flange_offset, np.eye(4), atol=1e-9)


@pytest.mark.parametrize("index", range(len(SETS)))
def test_factory_deltas_export_back(tmp_path, index):
    write_ur_file(tmp_path / "cal.conf", SETS[index])
    imported = factory_calibration.load(tmp_path / "cal.conf")
    cal = Calibration(nominal_mdh=imported.mdh, mdh=imported.mdh, model="ur10")
    exported = ur.to_ur(cal)
    assert exported.notes == []
    (tmp_path / "back.conf").write_text(exported.text)
    deltas, model = ur.read(tmp_path / "back.conf")
    assert model == "ur10"
    # The exported deltas, read back and evaluated in UR's convention (as the
    # controller would), give the same chain as the factory deltas.
    d, a, theta, alpha = nominal_ur10()
    q = random_poses(seed=10 + index)
    back = ur_dh_fk(
        d + deltas[:, kinematics.D] / 1000.0,
        a + deltas[:, kinematics.A] / 1000.0,
        theta + deltas[:, kinematics.THETA],
        alpha + deltas[:, kinematics.ALPHA],
        q,
    )
    s = SETS[index]
    factory = ur_dh_fk(
        d + s["d_m"], a + s["a_m"], theta + s["theta_rad"], alpha + s["alpha_rad"], q
    )
    np.testing.assert_allclose(back[:, :3, 3] * 1000.0, factory[:, :3, 3] * 1000.0, atol=1e-6)
    np.testing.assert_allclose(back[:, :3, :3], factory[:, :3, :3], atol=1e-9)


def test_ur10_model_reproduces_fw_kinematics_real():
    mdh = robots.get("ur10").mdh
    for case in DATA["ur10_fw_kinematics_real"]:
        pose = kinematics.chain(mdh, np.array([case["joints_rad"]]))[0]
        np.testing.assert_allclose(
            pose[:3, 3], np.array(case["expected_position_m"]) * 1000.0, rtol=0, atol=1e-6
        )


def test_ur_file_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.conf"
    bad.write_text("[mounting]\ndelta_theta = [1, 2]\n")
    with pytest.raises(ur.CalibrationError, match="delta_theta must be a list of six"):
        ur.read(bad, "ur10e")
    bad.write_text("[mounting]\n" + "\n".join(f"{k} = [0,0,0,0,0,NaN]" for k, _ in ur.KEYS))
    with pytest.raises(ur.CalibrationError, match="six finite numbers"):
        ur.read(bad, "ur10e")
    write_ur_file(bad, SETS[0])
    with pytest.raises(ur.CalibrationError, match="against ur10, not ur5e"):
        ur.read(bad, "ur5e")
