"""The command line as a user runs it: a real process, its output and exit code."""

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_kit import cli, one_line_error
from cli_process_kit import run_cli

from calibrator import calibration


def run(*args, cwd):
    return run_cli(*args, cwd=cwd)


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
    # Piped: the swarm's progress is plain key=value lines on stderr.
    assert (
        ident.stderr.strip()
        .splitlines()[-1]
        .startswith("progress task=swarm done=2000 total=2000 unit=generations")
    )
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


def test_bad_input_gives_one_line_and_exit_2(tmp_path):
    # In-process (the console entry point itself); one real process below.
    assert "not found" in one_line_error(cli("identify", "missing.parquet", cwd=tmp_path))
    (tmp_path / "junk.parquet").write_bytes(b"PAR1 nope")
    assert "not a readable Parquet" in one_line_error(cli("identify", "junk.parquet", cwd=tmp_path))
    cli("simulate", "-o", "few.parquet", "--poses", "6", "--no-orientation", cwd=tmp_path)
    assert "cannot identify" in one_line_error(cli("identify", "few.parquet", cwd=tmp_path))
    cli("simulate", "-o", "ok.parquet", "--poses", "10", cwd=tmp_path)
    assert "unknown model" in one_line_error(
        cli("identify", "ok.parquet", "--model", "kr16", cwd=tmp_path)
    )
    assert "unknown model" in one_line_error(cli("simulate", "--model", "kr16", cwd=tmp_path))
    (tmp_path / "cal.json").write_text("{}")
    assert "not a calibrator calibration" in one_line_error(
        cli("export-params", "cal.json", cwd=tmp_path)
    )
    assert "ref003 error table" in one_line_error(
        cli("simulate", "--model", "ur5e", "--errors", "ref003", cwd=tmp_path)
    )


def test_an_unwritable_output_is_one_line_from_a_real_process(tmp_path):
    cli("simulate", "-o", "s.parquet", "--poses", "30", cwd=tmp_path)
    result = run("identify", "s.parquet", "-o", "no/such/dir/cal.json", cwd=tmp_path)
    assert result.returncode == 2 and "Traceback" not in result.stderr
    assert result.stderr.strip() == (
        "calibrator: error: cannot write no/such/dir/cal.json: folder no/such/dir does not exist"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet", "s.truth.json"]


def test_docs_and_code_cite_no_file_outside_the_repository():
    repo = Path(__file__).resolve().parents[2]
    texts = [repo / "README.md", *(repo / "docs").glob("*.md")]
    texts += [*(repo / "calibrator").rglob("*.py"), *(repo / "drivers").rglob("*.py")]
    for path in texts:
        text = path.read_text()
        # Spelled in parts so this test is not itself a citation.
        for outside in ("shared/" + d for d in ("docs", "reference", "seeds", "")):
            assert outside not in text, f"{path.relative_to(repo)} cites {outside}"
