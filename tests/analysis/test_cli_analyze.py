"""``calibrator analyze`` as a user runs it: output, files, and one line + exit 2 on bad input."""

import json
import subprocess
import sys

import numpy as np
import pytest

from calibrator import calibration, models
from calibrator.cli import main


def run(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "calibrator", "analyze", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_misalignment_writes_figures_and_statistics(tmp_path):
    (tmp_path / "figs").mkdir()
    out = run(
        "misalignment", "--trials", "3000", "--sweep-r0", "0.025,0.05",
        "--sweep-length", "d3=800,1200", "--plots", "figs", "--json", "stats.json",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    assert "CDF 50%" in out.stdout and "density centre" in out.stdout and "about z" in out.stdout
    names = sorted(p.name for p in (tmp_path / "figs").iterdir())
    assert names == [
        "cloud.png", "cloud_d3-1200.png", "cloud_d3-800.png", "orientation.png",
        "pdf_cdf.png", "sweep_length.png", "sweep_r0.png",
    ]  # fmt: skip
    for name in names:
        assert (tmp_path / "figs" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doc = json.loads((tmp_path / "stats.json").read_text())
    assert [c["case"] for c in doc["cases"]] == ["base", "R0=0.025", "R0=0.05", "d3=800", "d3=1200"]
    base, half = doc["cases"][0]["position"], doc["cases"][1]["position"]
    assert half["cdf50"] == pytest.approx(base["cdf50"] / 2, rel=0.1)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figs", "stats.json"]  # no temp files


def test_tolerance_from_model_and_from_calibration_file(tmp_path):
    out = run(
        "tolerance", "--model", "ur10e", "--poses", "20", "--samples", "200",
        "--tol", "a2=0.2", "--json", "b.json", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["ranking"][0]["name"] == "a2"  # the loosened tolerance comes out on top
    assert "tighten first" in out.stdout and "linearisation error" in out.stdout

    mdh = models.get_model("er10l-c10").mdh.copy()
    mdh[1, 0] += 0.3
    cal = {"format": calibration.FORMAT, "version": calibration.VERSION, "model": "er10l-c10",
           "mdh": calibration.mdh_records(mdh), "nominal_mdh": mdh.tolist()}  # fmt: skip
    calibration.write(tmp_path / "cal.json", cal)
    out = run("tolerance", "--calibration", "cal.json", "--pose", "0,10,20,30,40,50", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "cal.json (identified table); 1 poses" in out.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["misalignment", "--r0", "abc"], "--r0 must be comma-separated numbers"),
        (["misalignment", "--h", "0"], "h must be finite and > 0"),
        (["misalignment", "--r0", "1,2"], "--r0 needs 1 or 6 values"),
        (["misalignment", "--sweep-length", "x3=1"], "unknown link length 'x3'"),
        (["misalignment", "--plots", "no/such/dir"], "--plots: folder no/such/dir does not exist"),
        (["misalignment", "--workers", "2", "--scheduler", "tcp://x:1"], "not both"),
        (["misalignment", "--workers", "0"], "--workers must be >= 1"),
        (["misalignment", "--trials", "0"], "--trials must be >= 1"),
        (["misalignment", "--model", "abb"], "unknown model 'abb'"),
        (["tolerance"], "exactly one of --model and --calibration"),
        (["tolerance", "--model", "ur5e", "--tol", "zz=1"], "unknown parameter 'zz'"),
        (["tolerance", "--model", "ur5e", "--tol", "a2=1,2"], "--tol a2 takes one value"),
        (["tolerance", "--model", "ur5e", "--length-tol", "-1"], "tolerances must be"),
        (["tolerance", "--calibration", "missing.json"], "calibration file not found"),
        (["tolerance", "--calibration", "c.json", "--json", "c.json"], "c.json is an input"),
    ],
)
def test_bad_options_give_one_line_and_exit_2(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_info:
        main(["analyze", *args])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert list(tmp_path.iterdir()) == []


def test_misalignment_json_is_atomic_and_numbers_match_the_api(tmp_path, capsys, monkeypatch):
    from calibrator.analysis import arm, engine
    from calibrator.analysis import misalignment as mc

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exit_info:
        main(["analyze", "misalignment", "--trials", "1500", "--seed", "4", "--json", "s.json"])
    assert exit_info.value.code == 0
    doc = json.loads((tmp_path / "s.json").read_text())
    summary, grid = engine.run(mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 1500, 4))
    expected = mc.statistics(summary, grid)
    assert doc["cases"][0]["position"] == json.loads(json.dumps(expected["position"]))
    assert np.isfinite(doc["cases"][0]["position"]["cdf98"])


@pytest.mark.parametrize("quiet", [False, True])
def test_long_runs_report_progress_on_stderr_unless_quiet(quiet, capsys):
    args = ["analyze", "misalignment", "--trials", "100000", "--chunk", "50000"]
    with pytest.raises(SystemExit) as exit_info:
        main(args + (["--quiet"] if quiet else []))
    assert exit_info.value.code == 0
    out, err = capsys.readouterr()
    assert "CDF 50%" in out and "trials (" not in out
    assert ("base: 100000/100000 trials (100 %" in err) is not quiet
    assert (err == "") is quiet
