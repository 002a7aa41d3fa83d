"""``calibrator analyze`` as a user runs it: output, files, and one line + exit 2 on bad input."""

import json
import signal
import subprocess
import sys

import numpy as np
import pytest
from analyze_kit import analyze, analyze_json
from cli_process_kit import start_cli

from calibrator import calibration, robots
from calibrator.cli import main


def write_calibration(path, model, **deltas):
    """A calibration.json as ``identify`` writes it: the model with some deltas identified."""
    nominal = robots.get(model).mdh
    mdh = nominal.copy()
    for name, value in deltas.items():
        mdh[int(name[-1]) - 1, "a alpha theta d beta".split().index(name[:-1])] += value
    cal = calibration.Calibration(
        nominal_mdh=nominal, mdh=mdh, free=tuple(deltas), deltas=deltas, model=model
    )
    cal.save(path)


def test_misalignment_writes_figures_and_statistics(tmp_path):
    (tmp_path / "figs").mkdir()
    out = analyze(
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
    out, doc = analyze_json(
        "tolerance", "--model", "ur10e", "--poses", "20", "--samples", "200",
        "--tol", "a2=0.2", "--json", "b.json", cwd=tmp_path,
    )  # fmt: skip
    assert doc["ranking"][0]["name"] == "a2"  # the loosened tolerance comes out on top
    assert "tighten first" in out.stdout and "linearisation error" in out.stdout

    write_calibration(tmp_path / "cal.json", "er10l-c10", a2=0.3)
    out = analyze(
        "tolerance", "--calibration", "cal.json", "--pose", "0,10,20,30,40,50", cwd=tmp_path
    )
    assert out.returncode == 0, out.stderr
    assert "cal.json (identified table); 1 poses" in out.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["misalignment", "--r0", "abc"], "--r0 must be comma-separated numbers"),
        (["misalignment", "--h", "0"], "--h: 0 mm is outside [1, 10000] mm"),
        (["misalignment", "--r0", "1,2"], "--r0 needs 1 or 6 values"),
        (["misalignment", "--sweep-length", "x3=1"], "unknown link length 'x3'"),
        (["misalignment", "--plots", "no/such/dir"], "folder no/such does not exist"),
        (["misalignment", "--workers", "2", "--scheduler", "tcp://x:1"], "not both"),
        (["misalignment", "--workers", "0"], "--workers: must be a whole number >= 1, got 0"),
        (["misalignment", "--trials", "0"], "--trials: must be a whole number >= 1, got 0"),
        (["misalignment", "--model", "abb"], "unknown model 'abb'"),
        (["tolerance"], "exactly one of --model and --calibration"),
        (["tolerance", "--model", "ur5e", "--tol", "zz=1"], "unknown parameter 'zz'"),
        (["tolerance", "--model", "ur5e", "--tol", "a2=1,2"], "--tol a2 takes one value"),
        (
            ["tolerance", "--model", "ur5e", "--length-tol", "-1"],
            "--length-tol: must be in [0, 100], got -1.0",
        ),
        (["tolerance", "--calibration", "missing.json"], "calibration file not found"),
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
def test_progress_on_stderr_unless_quiet(quiet, capsys):
    args = ["analyze", "misalignment", "--trials", "20000", "--chunk", "10000"]
    with pytest.raises(SystemExit) as exit_info:
        main(args + (["--quiet"] if quiet else []))
    assert exit_info.value.code == 0
    out, err = capsys.readouterr()
    assert "CDF 50%" in out and "task=" not in out
    assert ("task=misalignment base done=20000 total=20000 unit=trials" in err) is not quiet
    assert (err == "") is quiet


def test_tolerance_json_never_overwrites_its_calibration(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_calibration(tmp_path / "c.json", "ur5e", a2=0.1)
    before = (tmp_path / "c.json").read_bytes()
    with pytest.raises(SystemExit) as exit_info:
        main(["analyze", "tolerance", "--calibration", "c.json", "--json", "c.json"])
    assert exit_info.value.code == 2
    assert "it is an input of this command" in capsys.readouterr().err
    assert (tmp_path / "c.json").read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]


@pytest.mark.parametrize("workers", [[], ["--workers", "2"]])
def test_ctrl_c_ends_a_long_run_in_one_line_leaving_no_file(tmp_path, workers):
    # A real SIGINT to a real process, mid-computation (a run of minutes); with
    # two workers it lands while the cluster starts and a forked helper computes.
    proc = start_cli(
        "analyze",
        "misalignment",
        "--trials",
        "50000000",
        "-q",
        "--json",
        "s.json",
        *workers,
        cwd=tmp_path,
    )
    try:
        assert proc.stdout.readline()  # the run has begun: its first line is out
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130
    assert err == "calibrator: error: interrupted\n"
    assert "done in" not in out
    assert list(tmp_path.iterdir()) == []  # no JSON, no temporary file


def test_numpy_random_is_loaded_with_the_analysis_not_at_the_first_block():
    # A Ctrl-C that lands while numpy.random's compiled modules load is swallowed in
    # their set-up, and the run goes on: they load with the analysis module, which
    # the command imports before its first line (1 Ctrl-C in 6-12 was lost).
    code = (
        "import sys; import calibrator.analysis.misalignment;"
        " print('numpy.random._generator' in sys.modules)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120
    )
    assert out.stdout.strip() == "True"
