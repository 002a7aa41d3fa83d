"""The command line as a user runs it: a real process, its output and exit code."""

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

from calibrator import calibration


def run(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "calibrator", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_simulate_identify_export(tmp_path):
    sim = run(
        "simulate",
        "-o",
        "s.parquet",
        "--noise-mm",
        "0",
        "--orientation-noise-deg",
        "0",
        cwd=tmp_path,
    )
    assert sim.returncode == 0, sim.stderr
    ident = run("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    assert "24 free parameters" in ident.stdout
    assert "not identified: d2" in ident.stdout and "held-out poses (6)" in ident.stdout
    doc = json.loads((tmp_path / "cal.json").read_text())
    truth = json.loads((tmp_path / "s.truth.json").read_text())
    np.testing.assert_allclose(calibration.mdh_from_records(doc["mdh"]), truth["mdh"], atol=1e-6)
    assert doc["format"] == "calibrator.calibration" and doc["version"] == 1
    assert len(doc["free_parameters"]) == 24 and len(doc["dropped_parameters"]) == 6
    assert np.asarray(doc["base2tracker"]).shape == (4, 4)
    assert doc["stats"]["validation"]["after"]["position_mm"]["mean"] < 1e-6

    csv_out = run("export-params", "cal.json", "--format", "csv", "-o", "p.csv", cwd=tmp_path)
    assert csv_out.returncode == 0, csv_out.stderr
    table = pd.read_csv(tmp_path / "p.csv")
    joints = table[table.element.str.startswith("joint")]
    mdh = joints.pivot(index="element", columns="parameter", values="identified")
    np.testing.assert_allclose(
        mdh[["a_mm", "alpha_rad", "theta_rad", "d_mm", "beta_rad"]], truth["mdh"], atol=1e-6
    )
    json_out = run("export-params", "cal.json", "--format", "json", cwd=tmp_path)
    joints = json.loads(json_out.stdout)["joints"]
    assert [j["joint"] for j in joints] == [1, 2, 3, 4, 5, 6]
    assert joints[3]["d_mm"] == pytest.approx(truth["mdh"][3][3], abs=1e-6)


def test_tracker_frame_session_with_unknown_tool(tmp_path):
    run(
        "simulate",
        "-o",
        "t.parquet",
        "--model",
        "ur5e",
        "--frame",
        "tracker",
        "--tool-offset-mm",
        "5",
        "--poses",
        "30",
        cwd=tmp_path,
    )
    out = run("identify", "t.parquet", "--validation-fraction", "0", "--method", "lm", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "held-out poses: none" in out.stdout
    assert "not identified: theta1" in out.stdout and "base_rz" in out.stdout


def one_line_error(result):
    assert result.returncode == 2
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    return lines[0]


def test_bad_input_gives_one_line_and_exit_2(tmp_path):
    assert "not found" in one_line_error(run("identify", "missing.parquet", cwd=tmp_path))
    (tmp_path / "junk.parquet").write_bytes(b"PAR1 nope")
    assert "not a readable Parquet" in one_line_error(run("identify", "junk.parquet", cwd=tmp_path))
    run("simulate", "-o", "few.parquet", "--poses", "6", "--no-orientation", cwd=tmp_path)
    assert "cannot identify" in one_line_error(run("identify", "few.parquet", cwd=tmp_path))
    run("simulate", "-o", "ok.parquet", "--poses", "10", cwd=tmp_path)
    assert "unknown model" in one_line_error(
        run("identify", "ok.parquet", "--model", "kr16", cwd=tmp_path)
    )
    assert "unknown model" in one_line_error(run("simulate", "--model", "kr16", cwd=tmp_path))
    (tmp_path / "cal.json").write_text("{}")
    assert "not a calibrator calibration" in one_line_error(
        run("export-params", "cal.json", cwd=tmp_path)
    )
    assert "seed's error table" in one_line_error(
        run("simulate", "--model", "ur5e", "--errors", "seed", cwd=tmp_path)
    )


def test_an_unwritable_output_is_one_line(tmp_path):
    run("simulate", "-o", "s.parquet", "--poses", "30", cwd=tmp_path)
    line = one_line_error(
        run("identify", "s.parquet", "-o", "no/such/dir/cal.json", "--method", "lm", cwd=tmp_path)
    )
    assert "No such file" in line
