"""What ``identify`` prints and writes, checked against each other and the session.

The report table on stdout must show the numbers calibration.json holds,
calibration.json must hold the documented fields with the session's values,
and the exported JSON must carry the calibration's frames and model.
"""

import contextlib
import io
import json
import re

import numpy as np
import pytest

from calibrator import robots
from calibrator.cli import main
from calibrator.model import parameters
from calibrator.model.kinematics import FIELDS

NOMINAL = robots.get("er10l-c10").mdh


def cli(capsys, *args):
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main([str(a) for a in args])
    out = capsys.readouterr()
    assert info.value.code == 0, out.err
    return out.out


@pytest.fixture
def identified(tmp_path):
    # Function scope on purpose: mutmut credits a fixture's calls to the first
    # test that uses it, so each test must run identify itself to be chosen.
    session, cal = tmp_path / "s.parquet", tmp_path / "cal.json"
    # Captured by hand: the printed report is part of what is checked.
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        for args in (
            ("simulate", "-o", session, "--poses", 25, "--seed", 4),
            ("identify", session, "-o", cal, "--method", "lm", "--seed", 3, "--k", 2e4),
        ):
            with pytest.raises(SystemExit) as info:
                main([str(a) for a in args])
            assert info.value.code == 0
    return tmp_path, session, json.loads(cal.read_text()), out.getvalue()


def test_printed_table_shows_the_statistics_written(identified):
    *_, doc, printed = identified
    lines = printed.splitlines()
    header = next(line for line in lines if "mean" in line)
    assert header.split() == ["mean", "std", "max"]
    stats = doc["stats"]
    for part, title in (("fit", "fitted"), ("validation", "held-out")):
        start = lines.index(f"{title} poses ({stats[part]['before']['n']})")
        rows = lines[start + 1 : start + 9]
        labels = [("position (mm)", "position_mm", None)] + [
            (f"orientation {a.upper()} (deg)", "orientation_deg", a) for a in "xyz"
        ]
        k = 0
        for label, key, axis in labels:
            for when in ("before", "after"):
                row = rows[k]
                k += 1
                assert row.startswith(f"  {label} {when}"), row
                s = stats[part][when][key]
                s = s[axis] if axis else s
                numbers = [float(v) for v in row[len(f"  {label} {when}") :].split()]
                assert numbers == [round(s[m], 4) for m in ("mean", "std", "max")], row


def test_printed_summary_names_counts_and_dropped_parameters(identified):
    *_, doc, printed = identified
    n_val = len(doc["validation_poses"])
    assert f"{25 - n_val} fitted and {n_val} held-out poses" in printed
    assert f"{len(doc['free_parameters'])} free parameters, method lm" in printed
    for item in doc["dropped_parameters"]:
        assert re.search(rf"not identified: {item['name']}\s+{re.escape(item['reason'])}", printed)


def test_calibration_file_holds_the_documented_fields(identified):
    _, session, doc, _ = identified
    assert doc["format"] == "calibrator.calibration" and doc["version"] == 1
    assert doc["model"] == "er10l-c10"
    assert doc["session"] == str(session)
    np.testing.assert_array_equal(doc["nominal_mdh"], NOMINAL)
    assert [list(r) for r in doc["mdh"]] == [list(FIELDS)] * 6
    mdh = np.array([[r[f] for f in FIELDS] for r in doc["mdh"]])
    assert len(doc["free_parameters"]) == 24
    assert list(doc["deltas"]) == doc["free_parameters"]
    for name, value in doc["deltas"].items():
        i = parameters.MDH_NAMES.index(name)
        assert mdh.flat[i] - NOMINAL.flat[i] == pytest.approx(value, abs=1e-12), name
    free = set(doc["free_parameters"])
    fixed = [n for n in parameters.MDH_NAMES if n not in free]
    assert sorted(d["name"] for d in doc["dropped_parameters"]) == sorted(fixed)
    for name in fixed:
        i = parameters.MDH_NAMES.index(name)
        assert mdh.flat[i] == NOMINAL.flat[i]
    np.testing.assert_array_equal(doc["base2tracker"], np.eye(4))  # a base-frame session
    assert np.asarray(doc["flange2tool"]).shape == (4, 4)
    assert doc["method"] == "lm" and doc["seed"] == 3 and doc["k"] == 2e4
    assert doc["validation_fraction"] == 0.2
    assert len(doc["validation_poses"]) == 5 and all(
        isinstance(i, int) for i in doc["validation_poses"]
    )
    assert doc["stats"]["validation"]["after"]["n"] == 5
    solver = doc["solver"]["least_squares"]
    assert 0 < solver["evaluations"] < 200
    assert "satisfied" in solver["message"]  # scipy's reason for stopping, kept as text


def test_exported_json_carries_the_calibrations_model_and_frames(identified, capsys):
    tmp, _, doc, _ = identified
    cal = tmp / "cal.json"
    exported = json.loads(cli(capsys, "export-params", cal, "--format", "json"))
    assert exported["model"] == "er10l-c10"
    assert exported["convention"] == (
        "A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i)"
    )
    assert exported["base2tracker"] == doc["base2tracker"]
    assert exported["flange2tool"] == doc["flange2tool"]
    text = cli(capsys, "export-params", cal, "--format", "csv", "-o", tmp / "p.csv")
    assert text.strip().startswith(f"wrote {tmp / 'p.csv'}")


def test_table_without_orientation_and_with_one_or_no_held_out_pose(tmp_path, capsys):
    session = tmp_path / "p.parquet"
    cli(capsys, "simulate", "-o", session, "--poses", 25, "--no-orientation")
    for fraction, held_out in (("0.04", "held-out poses (1)"), ("0", "held-out poses: none")):
        printed = cli(
            capsys,
            "identify",
            session,
            "-o",
            tmp_path / "c.json",
            "--method",
            "lm",
            "--validation-fraction",
            fraction,
            "--force",  # the second fraction replaces the first one's file
        )
        assert held_out in printed
        assert "orientation X" not in printed
        assert "  position (mm) after" in printed
        validation = json.loads((tmp_path / "c.json").read_text())["stats"]["validation"]
        if fraction == "0":
            assert validation == {"before": {"n": 0}, "after": {"n": 0}}
        else:  # one pose: no spread to speak of, not NaN
            assert validation["after"]["n"] == 1
            assert validation["after"]["position_mm"]["std"] == 0.0
