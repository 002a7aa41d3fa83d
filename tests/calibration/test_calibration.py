"""calibration.json: strict JSON out, validated in, extra keys kept."""

import json
from dataclasses import replace

import numpy as np
import pytest
from cli_process_kit import run_cli  # the CLI as a user runs it: a real process

from calibrator import calibration, robots
from calibrator.calibration import Calibration
from calibrator.errors import CalibrationError
from calibrator.identify import pipeline
from calibrator.model import parameters


def result(uncertainty=None):
    """An identification result as the pipeline makes one."""
    nominal = robots.get("ur5e").mdh
    free, _ = parameters.structural_candidates(nominal, "base", True)
    space = parameters.ParameterSpace(nominal, free=free)
    x = np.random.default_rng(0).uniform(-1e-3, 1e-3, space.size)
    return pipeline.Result(
        space=space,
        x=x,
        dropped=[{"name": "d2", "reason": "parallel"}],
        stats={"fit": {"before": {"n": 3}, "after": {"n": 3}}},
        options=pipeline.Options(method="lm", seed=0, validation_fraction=0.2),
        k=1e4,
        fit_index=np.arange(3),
        validation_index=np.array([3, 4]),
        details={"least_squares": {"evaluations": np.int64(7)}},
        uncertainty=uncertainty or {},
        tool_known=True,
    )


def test_from_result_writes_its_parts_and_round_trips(tmp_path):
    unc = {"standard_errors": {"a1": np.float64(0.01)}, "residual_sigma": {"position_mm": 0.02}}
    cal = Calibration.from_result(result(unc), "s.parquet", "ur5e")
    cal.save(tmp_path / "c.json")
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["uncertainty"]["standard_errors"] == {"a1": 0.01}
    assert doc["solver"]["least_squares"]["evaluations"] == 7
    assert (doc["method"], doc["loss"], doc["seed"], doc["validation_fraction"]) == (
        "lm",
        "lsq",
        0,
        0.2,
    )
    assert (doc["noise_mm"], doc["tool_known"], doc["k"]) == (0.05, True, 1e4)
    assert doc["validation_poses"] == [3, 4] and doc["outliers"] == []
    record = {r["name"]: r for r in doc["parameters"]}
    assert record["beta2"]["free"] and not record["d2"]["free"]
    assert record["a2"]["nominal"] == -425.0 and record["a2"]["unit"] == "mm"
    back = calibration.load(tmp_path / "c.json")
    np.testing.assert_array_equal(back.mdh, cal.mdh)
    with pytest.raises(ValueError, match="read-only"):
        back.mdh[0, 0] = 1.0  # frozen, arrays included: derive with replace()
    assert back.free == cal.free and back.fit == cal.fit and back.provenance == cal.provenance
    assert back.diagnostics == {}


@pytest.mark.parametrize("where", ["uncertainty", "mdh"])
def test_save_refuses_non_finite(tmp_path, where):
    res = result({"standard_errors": [float("nan")]} if where == "uncertainty" else None)
    cal = Calibration.from_result(res)
    if where == "mdh":
        mdh = cal.mdh.copy()
        mdh[1, 1] = np.inf
        cal = replace(cal, mdh=mdh)
    with pytest.raises(CalibrationError, match="not a finite number"):
        cal.save(tmp_path / "c.json")
    assert list(tmp_path.iterdir()) == []


def good_doc():
    return Calibration.from_result(result(), model="ur5e").to_json()


def corrupt(doc, how):
    if how == "nan":
        return json.dumps(doc).replace('"k": 10000.0', '"k": NaN')
    if how == "infinity":
        return json.dumps(doc).replace('"k": 10000.0', '"k": Infinity')
    if how == "deep":
        return json.dumps(doc)[:-1] + ', "x": ' + "[" * 100000 + "]" * 100000 + "}"
    if how == "version_bool":
        doc["version"] = True
    elif how == "version_2":
        doc["version"] = 2
    elif how == "string_number":
        doc["mdh"][0]["a_mm"] = "0.0"
    elif how == "bool_number":
        doc["nominal_mdh"][0][0] = False
    elif how == "shape":
        doc["nominal_mdh"] = doc["nominal_mdh"][:5]
    elif how == "huge":
        doc["base2tracker"][0][3] = 1e308
    elif how == "not_rigid":
        doc["flange2tool"][0][0] = 2.0
    elif how == "fixed_changed":
        doc["mdh"][1]["d_mm"] = 1.0
    elif how == "metres":
        doc["mdh"][1]["a_mm"] /= 1000.0
        doc["nominal_mdh"][1][0] /= 1000.0
        doc["mdh"][2]["a_mm"] = doc["nominal_mdh"][2][0] + 300.0
    elif how == "unknown_free":
        doc["free_parameters"].append("zz")
    elif how == "deltas":
        doc["deltas"].pop(next(iter(doc["deltas"])))
    elif how == "record_keys":
        doc["mdh"][3].pop("beta_rad")
    elif how == "frame":
        doc["frame"] = "world"
    return json.dumps(doc)


CASES = {
    "nan": "NaN is not allowed",
    "infinity": "Infinity is not allowed",
    "deep": "is not JSON",
    "version_bool": "version True is not supported",
    "version_2": "version 2 is not supported",
    "string_number": r"mdh\[0\]\[0\] must be a number",
    "bool_number": r"nominal_mdh\[0\]\[0\] must be a number",
    "shape": "'nominal_mdh' must be a 6x5 table",
    "huge": "not a finite, sane number",
    "not_rigid": "not a proper rotation",
    "fixed_changed": "d2 is not a free parameter",
    "metres": "a3 differs from nominal by 300 mm",
    "unknown_free": "has unknown names",
    "deltas": "'deltas' must map each free parameter",
    "record_keys": "joint 4 must have exactly the keys",
    "frame": "'frame' must be 'base' or 'tracker'",
}


@pytest.mark.parametrize("how", sorted(CASES))
def test_load_refuses_bad_files(tmp_path, how):
    path = tmp_path / "c.json"
    path.write_text(corrupt(good_doc(), how))
    with pytest.raises(CalibrationError, match=CASES[how]):
        calibration.load(path)


def test_export_params_refuses_bad_file_in_one_line(tmp_path):
    (tmp_path / "c.json").write_text(corrupt(good_doc(), "nan"))
    out = run_cli("export-params", "c.json", "-o", "p.csv", cwd=tmp_path)
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "NaN" in out.stderr
    assert not (tmp_path / "p.csv").exists()
