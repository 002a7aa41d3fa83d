"""calibration.json: what :func:`calibration.load` accepts and what it refuses
(one line, naming the file and the key), what :meth:`Calibration.from_result`
keeps, and the exact JSON a calibration becomes."""

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from calibrator import calibration, outputs, robots
from calibrator.calibration import Calibration, FitReport, Provenance
from calibrator.errors import CalibrationError
from calibrator.identify import pipeline
from calibrator.model import frames, parameters, rotations
from calibrator.recorded_options import Options

NOMINAL = robots.get("ur5e").mdh
KEYS = ("a_mm", "alpha_rad", "theta_rad", "d_mm", "beta_rad")
FREE = parameters.structural_candidates(NOMINAL, "base", True)[0]


def good_cal():
    mdh = NOMINAL.copy()
    mdh[1, 0] += 0.25  # a2, free
    mdh[1, 4] = 0.001  # beta2, free
    base2tracker = frames.transform(rotations.rotations_xyz([0.1, -0.2, 0.3]), [100.0, 0, 5.0])
    flange2tool = frames.transform(rotations.rotations_xyz([0.0, 0.05, -0.1]), [1.0, 2.0, 90.0])
    base0 = frames.transform(None, [99.0, 0.0, 5.0])
    tool0 = frames.transform(None, [0.0, 0.0, 90.0])
    space = parameters.ParameterSpace(NOMINAL, base0, tool0, tuple(FREE + ["tool_x"]))
    return Calibration(
        nominal_mdh=NOMINAL,
        mdh=mdh,
        base2tracker=base2tracker,
        flange2tool=flange2tool,
        free=FREE + ["tool_x"],
        deltas=dict(zip(space.free, space.pack(mdh, base2tracker, flange2tool), strict=True)),
        dropped=[{"name": "d2", "reason": "parallel axes"}],
        model="ur5e",
        frame="tracker",
        base0=base0,
        tool0=tool0,
        session="s.parquet",
        provenance=Provenance.from_json({"method": "lm"}),  # records the method only
        fit=FitReport(stats={"fit": [1.5, 2]}),
        diagnostics={"note": "kept"},
    )


def doc():
    return good_cal().to_json()


def write(tmp_path, document):
    """``document`` (bytes, text, or a dict to dump) as tmp_path/c.json."""
    path = tmp_path / "c.json"
    if isinstance(document, bytes):
        path.write_bytes(document)
    else:
        path.write_text(document if isinstance(document, str) else json.dumps(document))
    return path


def refused(tmp_path, document):
    path = write(tmp_path, document)
    with pytest.raises(CalibrationError) as info:
        calibration.load(path)
    return str(info.value), path


def test_a_saved_calibration_loads_back_field_by_field(tmp_path):
    cal = good_cal()
    cal.save(tmp_path / "c.json")
    back = calibration.load(tmp_path / "c.json")
    for name in ("nominal_mdh", "mdh", "base2tracker", "flange2tool", "base0", "tool0"):
        np.testing.assert_array_equal(getattr(back, name), getattr(cal, name))
    assert back.free == tuple(cal.free) and back.deltas == cal.deltas
    assert back.dropped == cal.dropped and back.model == "ur5e" and back.frame == "tracker"
    assert back.session == "s.parquet"
    assert back.diagnostics == {"note": "kept"}
    assert back.fit == cal.fit and back.provenance == cal.provenance
    assert Calibration.load(tmp_path / "c.json").mdh.tolist() == cal.mdh.tolist()


def test_the_json_document_holds_each_typed_key():
    d = doc()
    assert d["format"] == "calibrator.calibration" and d["version"] == 1
    assert d["mdh"][1] == {
        "a_mm": NOMINAL[1, 0] + 0.25,
        "alpha_rad": NOMINAL[1, 1],
        "theta_rad": NOMINAL[1, 2],
        "d_mm": NOMINAL[1, 3],
        "beta_rad": 0.001,
    }
    assert d["nominal_mdh"] == NOMINAL.tolist()
    assert d["free_parameters"] == FREE + ["tool_x"]
    assert d["dropped_parameters"] == [{"name": "d2", "reason": "parallel axes"}]
    assert d["session"] == "s.parquet" and d["frame"] == "tracker" and d["model"] == "ur5e"
    np.testing.assert_array_equal(calibration.mdh_from_records(d["mdh"]), good_cal().mdh)


def test_typed_keys_win_over_diagnostics_of_the_same_name():
    cal = replace(good_cal(), diagnostics={"model": "other", "version": 9, "note": "kept"})
    d = cal.to_json()
    assert d["model"] == "ur5e" and d["version"] == 1 and d["note"] == "kept"


def test_parameter_records_hold_nominal_and_identified_values():
    records = {r["name"]: r for r in good_cal().parameter_records()}
    assert list(records) == list(parameters.ALL_NAMES)
    assert records["a2"] == {
        "name": "a2",
        "unit": "mm",
        "nominal": NOMINAL[1, 0],
        "identified": NOMINAL[1, 0] + 0.25,
        "delta": 0.25,
        "free": True,
    }
    assert records["beta2"]["unit"] == "rad" and records["beta2"]["identified"] == 0.001
    assert records["d2"]["free"] is False
    assert records["base_tx"]["nominal"] == 99.0 and records["base_tx"]["identified"] == 100.0
    assert records["base_rz"]["identified"] == pytest.approx(0.3, abs=1e-12)
    assert records["base_rz"]["nominal"] == 0.0
    assert records["tool_z"]["identified"] == 90.0 and records["tool_y"]["identified"] == 2.0
    assert records["tool_ry"]["identified"] == pytest.approx(0.05, abs=1e-12)
    assert records["tool_rz"]["identified"] == pytest.approx(-0.1, abs=1e-12)
    assert records["tool_x"]["free"] is True and records["tool_y"]["free"] is False


def test_optional_keys_take_their_defaults(tmp_path):
    d = doc()
    for key in ("base0", "tool0", "deltas", "dropped_parameters", "frame", "model", "session"):
        d.pop(key)
    d["free_parameters"] = []
    d["mdh"] = calibration.mdh_records(NOMINAL)
    cal = calibration.load(write(tmp_path, d))
    np.testing.assert_array_equal(cal.base0, np.eye(4))
    np.testing.assert_array_equal(cal.tool0, np.eye(4))
    assert cal.deltas == {} and cal.dropped == [] and cal.frame == "base"
    assert cal.model is None and cal.session is None


def test_a_missing_or_huge_file_is_refused(tmp_path):
    with pytest.raises(CalibrationError) as info:
        calibration.load(tmp_path / "none.json")
    assert str(info.value) == f"calibration file not found: {tmp_path / 'none.json'}"
    text = json.dumps(doc())
    path = tmp_path / "c.json"
    # Exactly the limit is accepted; one byte more is refused.
    path.write_text(text + " " * (calibration.MAX_BYTES - len(text)))
    assert calibration.load(path).model == "ur5e"
    message, _ = refused(tmp_path, text + " " * (calibration.MAX_BYTES - len(text) + 1))
    assert message == f"{path}: {calibration.MAX_BYTES + 1} bytes is too large for a calibration"


@pytest.mark.parametrize("content", [b"{", b'{"format": "\xff"}', b"[" * 100000])
def test_not_json_is_refused(tmp_path, content):
    message, path = refused(tmp_path, content)
    assert message == f"{path} is not JSON"


def test_nan_is_named(tmp_path):
    text = json.dumps(doc()).replace('"method": "lm"', '"method": -Infinity')
    message, path = refused(tmp_path, text)
    assert message == f"{path}: method: -Infinity is not allowed (strict JSON)"


def edit(**changes):
    d = doc()
    for key, value in changes.items():
        if value is KeyError:
            d.pop(key)
        else:
            d[key] = value
    return d


CASES = [
    (["not", "a", "dict"], "{path} is not a calibrator calibration file"),
    (edit(format="other"), "{path} is not a calibrator calibration file"),
    (edit(format=KeyError), "{path} is not a calibrator calibration file"),
    (
        edit(version=1.0),
        "{path}: calibration version 1.0 is not supported (this program reads version 1)",
    ),
    (
        edit(version=KeyError),
        "{path}: calibration version None is not supported (this program reads version 1)",
    ),
    (edit(mdh={"a": 1}), "{path}: 'mdh' must be a list of six joints"),
    (edit(mdh=doc()["mdh"][:5]), "{path}: 'mdh' must be a list of six joints"),
    (
        edit(mdh=doc()["mdh"][:5] + [[0, 0, 0, 0, 0]]),
        "{path}: 'mdh' joint 6 must have exactly the keys " + ", ".join(KEYS),
    ),
    (
        edit(mdh=doc()["mdh"][:2] + [{**doc()["mdh"][2], "x": 1}] + doc()["mdh"][3:]),
        "{path}: 'mdh' joint 3 must have exactly the keys " + ", ".join(KEYS),
    ),
    (edit(nominal_mdh=KeyError), "{path}: 'nominal_mdh' must be a 6x5 table of numbers"),
    (
        edit(nominal_mdh=[r[:4] for r in NOMINAL.tolist()]),
        "{path}: 'nominal_mdh' must be a 6x5 table of numbers",
    ),
    (
        edit(nominal_mdh=NOMINAL.tolist()[:5] + [[1, 2, 3, 4]]),
        "{path}: 'nominal_mdh' must be a 6x5 table of numbers",
    ),
    (edit(tool0=np.eye(4)[:3].tolist()), "{path}: 'tool0' must be a 4x4 table of numbers"),
    (edit(base2tracker=KeyError), "{path}: 'base2tracker' must be a 4x4 table of numbers"),
    (
        edit(flange2tool=[[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 2]]),
        "{path}: flange2tool must have a last row [0, 0, 0, 1]",
    ),
    (edit(free_parameters="a2"), "{path}: 'free_parameters' must be a list of names"),
    (edit(free_parameters=["a2", 3]), "{path}: 'free_parameters' must be a list of names"),
    (
        edit(free_parameters=FREE + ["tool_x", "a2"]),
        "{path}: 'free_parameters' repeats a2",
    ),
    (edit(deltas=[]), "{path}: 'deltas' must map each free parameter to its value"),
    (
        edit(deltas={**dict.fromkeys(FREE + ["tool_x"], 0.0), "a2": "x" * 60}),
        "{path}: deltas.a2 must be a number, got 'xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx",
    ),
    (
        edit(deltas={**dict.fromkeys(FREE + ["tool_x"], 0.0), "a2": 1.5e12}),
        "{path}: deltas.a2 is not a finite, sane number",
    ),
    (
        edit(dropped_parameters={"name": "d2"}),
        "{path}: 'dropped_parameters' must be a list of {{name, reason}}",
    ),
    (
        edit(dropped_parameters=[{"name": "d2", "reason": 1}]),
        "{path}: 'dropped_parameters' must be a list of {{name, reason}}",
    ),
    (
        edit(dropped_parameters=[{"name": None, "reason": "r"}]),
        "{path}: 'dropped_parameters' must be a list of {{name, reason}}",
    ),
    (
        edit(dropped_parameters=["d2"]),
        "{path}: 'dropped_parameters' must be a list of {{name, reason}}",
    ),
    (edit(model=5), "{path}: 'model' must be a string or null"),
    (edit(session=["s"]), "{path}: 'session' must be a string or null"),
    (edit(frame=None), "{path}: 'frame' must be 'base' or 'tracker', got None"),
]


@pytest.mark.parametrize(("document", "message"), CASES)
def test_bad_documents_are_refused_naming_the_key(tmp_path, document, message):
    got, path = refused(tmp_path, document)
    assert got == message.format(path=path)


def test_numbers_up_to_a_trillion_are_sane(tmp_path):
    d = doc()
    d["deltas"]["a2"] = -1e12  # sane as a number; refused as not what the tables give
    got, path = refused(tmp_path, d)
    assert got.startswith(f"{path}: deltas.a2 is -1e+12 mm but mdh minus nominal_mdh gives")
    d["deltas"]["a2"] = 1e12 + 0.5
    got, path = refused(tmp_path, d)
    assert got == f"{path}: deltas.a2 is not a finite, sane number"
    d["deltas"]["a2"] = True
    got, path = refused(tmp_path, d)
    assert got == f"{path}: deltas.a2 must be a number, got True"


def test_fixed_parameters_must_equal_their_nominal_to_a_nanometre(tmp_path):
    d = doc()
    d["mdh"][1]["d_mm"] = NOMINAL[1, 3] + 0.9e-9  # d2 is fixed: rounding is fine
    assert calibration.load(write(tmp_path, d)).mdh[1, 3] == NOMINAL[1, 3] + 0.9e-9
    d["mdh"][1]["d_mm"] = NOMINAL[1, 3] - 2e-9
    got, path = refused(tmp_path, d)
    assert got == (
        f"{path}: d2 is not a free parameter but differs from its nominal value by -2e-09 mm"
    )


@pytest.mark.parametrize(
    ("row", "col", "name", "delta", "unit", "ok"),
    [
        (1, 0, "a2", 99.5, "mm", True),
        (1, 0, "a2", -100.5, "mm", False),
        (1, 4, "beta2", 0.49, "rad", True),
        (1, 4, "beta2", 0.51, "rad", False),
    ],
)
def test_free_parameters_stay_within_a_plausible_distance(
    tmp_path, row, col, name, delta, unit, ok
):
    d = doc()
    d["mdh"][row][calibration.kinematics.FIELDS[col]] = NOMINAL[row, col] + delta
    d["deltas"][name] = delta  # consistent with the table
    if ok:
        assert calibration.load(write(tmp_path, d)).mdh[row, col] == NOMINAL[row, col] + delta
        return
    got, path = refused(tmp_path, d)
    limit = {"mm": 100, "rad": 0.5}[unit]
    assert got == (
        f"{path}: {name} differs from nominal by {delta:.6g} {unit}, more than {limit:g} {unit}: "
        "a unit mistake or the wrong nominal model?"
    )


def test_save_names_the_first_non_finite_value(tmp_path):
    cal = replace(good_cal(), fit=FitReport(stats={"fit": [1.0, {"max": math.nan}]}))
    with pytest.raises(CalibrationError) as info:
        cal.save(tmp_path / "c.json")
    assert str(info.value) == (
        f"refusing to write {tmp_path / 'c.json'}: stats.fit[1].max is not a finite number "
        "(calibration files are strict JSON)"
    )
    cal = replace(cal, fit=FitReport(), provenance=Provenance(options=Options(k=math.inf)))
    with pytest.raises(CalibrationError, match=r": k is not a finite number"):
        cal.save(tmp_path / "c.json")
    mdh = cal.mdh.copy()
    mdh[2, 1] = -math.inf
    cal = replace(cal, provenance=Provenance(), mdh=mdh)
    with pytest.raises(CalibrationError, match=r": mdh\[2\]\.alpha_rad is not a finite number"):
        cal.save(tmp_path / "c.json")
    assert list(tmp_path.iterdir()) == []


def test_save_in_a_batch_appears_with_the_batch(tmp_path):
    cal = good_cal()
    with outputs.Outputs() as batch:
        cal.save(tmp_path / "c.json", batch=batch)
        assert not (tmp_path / "c.json").exists()
    text = (tmp_path / "c.json").read_text()
    assert text.endswith("}\n") and text.startswith('{\n  "')
    assert json.loads(text) == cal.to_json()


def result(**fields):
    nominal = NOMINAL
    free = FREE + ["base_tx", "base_rz", "tool_x"]
    space = parameters.ParameterSpace(
        nominal,
        free=free,
        base0=frames.transform(rotations.rotations_xyz([0.0, 0.0, 0.4]), [1500.0, -20.0, 3.0]),
        tool0=frames.transform(None, [0.0, 0.0, 120.0]),
    )
    x = np.linspace(-1e-3, 1e-3, space.size)
    values = dict(
        space=space,
        x=x,
        dropped=({"name": "d2", "reason": "parallel"},),
        stats={},
        options=pipeline.Options(),
        k=0.0,
        fit_index=np.arange(3),
        validation_index=np.array([], dtype=int),
    )
    return pipeline.Result(**{**values, **fields}), space, x


def test_from_result_keeps_the_solution_provenance_and_fit_report():
    res, space, x = result(
        options=pipeline.Options(
            method="pso", seed=7, validation_fraction=0.25, loss="huber", noise_mm=0.03
        ),
        k=250.0,
        tool_known=True,
        validation_index=np.array([3, 4], dtype=np.int64),
        details={"iterations": np.int32(9), "ok": np.bool_(True), "r": np.float32(0.5)},
        stats={"n": np.int64(5), "pair": (1, 2)},
        warnings=["w"],
        outliers=[np.int64(8)],
    )
    origin = Provenance(session_sha256="ab" * 32, versions={"numpy": "1"}, created="now")
    cal = Calibration.from_result(res, Path("s.parquet"), "ur5e", "tracker", origin)
    mdh, base, tool = space.unpack(x)
    np.testing.assert_array_equal(cal.mdh, mdh)
    np.testing.assert_array_equal(cal.base2tracker, base)
    np.testing.assert_array_equal(cal.flange2tool, tool)
    assert cal.free == space.free and cal.deltas == dict(zip(space.free, x.tolist(), strict=True))
    assert np.abs(cal.base2tracker - np.eye(4)).max() > 1.0  # a real base frame
    assert np.abs(cal.base0 - np.eye(4)).max() > 1.0 and cal.tool0[2, 3] == 120.0
    assert cal.dropped == [{"name": "d2", "reason": "parallel"}]
    assert (cal.model, cal.frame, cal.session) == ("ur5e", "tracker", "s.parquet")
    np.testing.assert_array_equal(cal.base0, space.base0)
    np.testing.assert_array_equal(cal.tool0, space.tool0)
    origin = cal.provenance
    g = origin.options
    assert g is not None and origin.unrecorded == frozenset()
    assert (g.method, g.seed, g.validation_fraction, g.loss, g.noise_mm, g.k) == (
        "pso",
        7,
        0.25,
        "huber",
        0.03,
        250.0,
    )
    assert g.tool_known is True and origin.session_sha256 == "ab" * 32
    assert (origin.versions, origin.created, g.generations, g.swarm_poses) == (
        {"numpy": "1"},
        "now",
        2000,
        32,
    )
    f = cal.fit
    assert f.validation_poses == [3, 4] and type(f.validation_poses[0]) is int
    assert f.solver == {"iterations": 9, "ok": True, "r": 0.5}
    assert type(f.solver["iterations"]) is int and type(f.solver["ok"]) is bool
    assert f.stats == {"n": 5, "pair": [1, 2]}
    assert f.outliers == [8] and type(f.outliers[0]) is int and f.warnings == ["w"]
    assert cal.diagnostics == {}
    json.dumps(cal.to_json(), allow_nan=False)  # plain JSON values only


def test_a_file_without_provenance_reads_as_not_recorded():
    doc = good_cal().to_json()
    for key in ("method", "seed", "loss", "noise_mm", "tool_known", "k", "outliers", "stats"):
        doc.pop(key, None)
    back = calibration.from_json(doc)
    assert back.provenance.recorded() == {} and back.fit.outliers == []
    assert back.provenance.options is None and back.fit.stats == {}


def test_outlier_poses_is_read_as_outliers():
    doc = dict(good_cal().to_json(), outlier_poses=[4, 9])
    doc.pop("outliers", None)
    assert calibration.from_json(doc).fit.outliers == [4, 9]


@pytest.mark.parametrize(
    ("key", "value", "says"),
    [
        ("noise_mm", "0.05", "'noise_mm' must be a JSON number"),
        ("seed", 1.5, "'seed' must be a JSON integer"),
        ("seed", True, "'seed' must be a JSON integer"),
        ("tool_known", 1, "'tool_known' must be a JSON boolean"),
        ("outliers", [1.5], "'outliers' must be a list of pose numbers"),
        ("stats", [], "'stats' must be a JSON object"),
    ],
)
def test_provenance_and_fit_keys_of_the_wrong_type_are_refused(key, value, says):
    doc = dict(good_cal().to_json(), **{key: value})
    with pytest.raises(CalibrationError, match=re.escape(says)):
        calibration.from_json(doc, "c.json")


def test_write_refuses_non_finite_json_and_leaves_nothing(tmp_path):
    with pytest.raises(ValueError):
        calibration.write(tmp_path / "d.json", {"a": [1.0, math.nan]})
    assert list(tmp_path.iterdir()) == []
    calibration.write(tmp_path / "d.json", {"a": [1.0, 2]})
    assert (tmp_path / "d.json").read_text() == '{\n  "a": [\n    1.0,\n    2\n  ]\n}\n'


def test_a_file_without_base0_still_reads_its_tool0(tmp_path):
    d = doc()
    d.pop("base0")
    cal = calibration.load(write(tmp_path, d))
    np.testing.assert_array_equal(cal.base0, np.eye(4))
    assert cal.tool0[2, 3] == 90.0
