"""What the exported files say, value by value, through the command line (in process).

The expectations come from the simulation's truth and the named model, not
from the exporter: a flipped delta, a "nominal" block that holds the
compensated values, or an unchecked calibration version all fail here.
Columns are found by name (``delta`` in the name, units as the name's
suffix), so the test does not depend on the column order.
"""

import json

import numpy as np
import pandas as pd
import pytest

from calibrator import robots
from calibrator.cli import main
from calibrator.model.kinematics import COLUMNS

NOMINAL = robots.get("er10l-c10").mdh
#: How to turn a value in the unit its column names into mm / rad.
TO_INTERNAL = {"mm": 1.0, "rad": 1.0, "deg": np.pi / 180.0}


def cli(*args):
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    return info.value.code


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cal")
    session, cal = tmp / "s.parquet", tmp / "cal.json"
    noise = ("--noise-mm", 0, "--orientation-noise-deg", 0)
    assert cli("simulate", "-o", session, "--poses", 24, "--seed", 7, *noise) == 0
    assert cli("identify", session, "-o", cal, "--method", "lm") == 0
    truth = np.array(json.loads((tmp / "s.truth.json").read_text())["mdh"])
    return tmp, cal, truth


def table_by_role(frame, role):
    """(6, 5) array, mm and rad, of the values of one role, found by column name.

    Reads the wide layout (one row per joint, ``delta_a_mm`` ...) and the long
    one (one row per parameter: ``element, parameter, nominal, identified,
    delta``), so the test holds whichever the exporter writes.
    """
    out = np.full((6, 5), np.nan)
    if "parameter" in frame.columns:
        column = {"value": "identified", "nominal": "nominal", "delta": "delta"}[role]
        for _, row in frame[frame["element"].str.startswith("joint")].iterrows():
            stem, unit = row["parameter"].rsplit("_", 1)
            j = int(row["element"].removeprefix("joint")) - 1
            out[j, COLUMNS.index(stem)] = row[column] * TO_INTERNAL[unit]
        return out

    def role_of(name):
        name = name.lower()
        return "delta" if "delta" in name else "nominal" if "nominal" in name else "value"

    cols = [c for c in frame.columns if c.lower() != "joint" and role_of(c) == role]
    assert len(cols) == 5, (role, list(frame.columns))
    for c in cols:
        stem, unit = c.rsplit("_", 1)
        field = stem.split("_")[-1]
        out[:, COLUMNS.index(field)] = frame[c].to_numpy() * TO_INTERNAL[unit]
    assert frame["joint"].tolist() == [1, 2, 3, 4, 5, 6]
    return out


def test_csv_deltas_are_identified_minus_nominal(calibrated, capsys):
    tmp, cal, truth = calibrated
    out = tmp / "p.csv"
    assert cli("export-params", cal, "--format", "csv", "-o", out) == 0
    text = out.read_bytes()
    assert b"\r" not in text and text.endswith(b"\n")  # one row per joint, Unix line ends
    frame = pd.read_csv(out)
    value, nominal, delta = (table_by_role(frame, r) for r in ("value", "nominal", "delta"))
    np.testing.assert_allclose(nominal, NOMINAL, rtol=0, atol=1e-12)
    np.testing.assert_allclose(value, truth, rtol=0, atol=1e-6)
    np.testing.assert_allclose(delta, value - nominal, rtol=0, atol=1e-11)
    np.testing.assert_allclose(delta, truth - NOMINAL, rtol=0, atol=1e-6)
    assert np.abs(delta).max() > 0.1  # the IPSO paper's errors: not a trivial zero


def test_json_nominal_block_is_the_nominal_arm(calibrated, capsys):
    tmp, cal, truth = calibrated
    out = tmp / "p.json"
    assert cli("export-params", cal, "--format", "json", "-o", out) == 0
    joints = json.loads(out.read_text())["joints"]
    assert [j["joint"] for j in joints] == [1, 2, 3, 4, 5, 6]
    for row, (joint, nominal, true) in enumerate(zip(joints, NOMINAL, truth, strict=True)):
        for col, name in enumerate(COLUMNS):
            [key] = [k for k in joint if k.split("_")[0] == name]
            unit = TO_INTERNAL[key.rsplit("_", 1)[1]]
            assert joint[key] * unit == pytest.approx(true[col], abs=1e-6), (row, key)
            assert joint["nominal"][key] * unit == pytest.approx(nominal[col], abs=1e-12)


@pytest.mark.parametrize("version", [0, 2, "1", None])
def test_a_calibration_of_another_version_is_refused(calibrated, capsys, version):
    tmp, cal, _ = calibrated
    doc = json.loads(cal.read_text())
    doc["version"] = version
    other = tmp / f"v{version}.json"
    other.write_text(json.dumps(doc))
    capsys.readouterr()
    assert cli("export-params", other, "--format", "csv", "-o", tmp / "x.csv") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "version" in err[0]
    assert not (tmp / "x.csv").exists()


@pytest.mark.parametrize(
    ("content", "words"),
    [
        (None, ["not found"]),
        ("{not json", ["not JSON"]),
        ("[1, 2]", ["not a calibrator calibration file"]),
        ({"format": "calibrator.session", "version": 1}, ["not a calibrator calibration file"]),
        ("version", ["version 7", "version 1"]),
        ("mdh", ["'mdh'", "a_mm, alpha_rad, theta_rad, d_mm, beta_rad"]),
        ("nominal", ["'nominal_mdh'"]),
    ],
)
def test_a_bad_calibration_file_is_one_line_naming_the_file(calibrated, capsys, content, words):
    tmp, cal, _ = calibrated
    bad = tmp / "bad.json"
    bad.unlink(missing_ok=True)
    doc = json.loads(cal.read_text())
    if content == "version":
        doc["version"] = 7
    elif content == "mdh":
        del doc["mdh"][2]["d_mm"]
    elif content == "nominal":
        doc["nominal_mdh"] = doc["nominal_mdh"][:5]
    if content in ("version", "mdh", "nominal"):
        bad.write_text(json.dumps(doc))
    elif isinstance(content, dict):
        bad.write_text(json.dumps(content))
    elif content is not None:
        bad.write_text(content)
    capsys.readouterr()
    assert cli("export-params", bad, "--format", "json") == 2
    out = capsys.readouterr()
    assert out.out == ""
    [line] = out.err.strip().splitlines()
    assert str(bad) in line
    for word in words:
        assert word in line
