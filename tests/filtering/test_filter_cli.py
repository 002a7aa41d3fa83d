"""``calibrator compensate`` on programs as a user runs it: exit codes, outputs, refusals."""

import json

import numpy as np
from cli_process_kit import run_cli
from filter_kit import calibration, work_joints
from program_kit import write_krl_program


def test_krl_program_through_the_command_line(tmp_path):
    cal = calibration()
    cal.save(tmp_path / "cal.json")
    src, config = write_krl_program(tmp_path, cal, work_joints(8))
    (tmp_path / "out").mkdir()
    done = run_cli(
        "compensate", "cal.json", "weld.src", "-o", "out/weld.src", "--config-dat", config.name,
        "--summary", "s.json", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "out" / "weld.dat").exists() and (tmp_path / "out" / "weld.src").exists()
    doc = json.loads((tmp_path / "s.json").read_text())
    assert doc["targets"]["pose"]["corrected"] == 8 and doc["failed"] == []
    assert doc["outputs"] == ["out/weld.dat", "out/weld.src"]


def test_a_failed_target_writes_nothing_and_exits_1(tmp_path):
    cal = calibration()
    cal.save(tmp_path / "cal.json")
    q = work_joints(8)
    q[1, 1], q[1, 2] = 0.3, np.radians(-82.5) + 0.005  # out of the calibrated arm's reach
    src, config = write_krl_program(tmp_path, cal, q)
    done = run_cli(
        "compensate", "cal.json", "weld.src", "-o", "f.src", "--config-dat", config.name,
        "--summary", "s.json", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 1
    assert "weld.dat:6: XP2: the calibrated arm cannot reach it" in done.stderr
    assert not (tmp_path / "f.src").exists() and not (tmp_path / "f.dat").exists()
    assert json.loads((tmp_path / "s.json").read_text())["failed_total"] == 1
    kept = run_cli(
        "compensate", "cal.json", "weld.src", "-o", "f.src", "--config-dat", config.name,
        "--keep-failed", cwd=tmp_path,
    )  # fmt: skip
    assert kept.returncode == 1 and (tmp_path / "f.dat").exists()
    line = (tmp_path / "f.dat").read_bytes().decode("cp1252").split("\r\n")[5]
    assert line.startswith("DECL E6POS XP2=") and "; not corrected: the calibrated arm" in line


def test_bad_options_and_files_are_refused_in_one_line(tmp_path):
    cal = calibration()
    cal.save(tmp_path / "cal.json")
    write_krl_program(tmp_path, cal, work_joints(2))
    (tmp_path / "f.yaml").write_text(
        "tools:\n"
        "  '1': {xyz_mm: [0, 0, 1], abc_deg: [0, 0, 0]}\n"
        "  '1': {xyz_mm: [0, 0, 2], abc_deg: [0, 0, 0]}\n"
    )
    cases = [
        (["--frames", "f.yaml"], "key '1' appears more than once"),
        (["--max-correction", "5"], "--max-correction needs MM,DEG"),
        (["--joint-targets", "fix"], "--joint-targets must be keep or correct"),
        (["--format", "rapid"], "does not end in"),
    ]
    for extra, message in cases:
        done = run_cli("compensate", "cal.json", "weld.src", "-o", "o.src", *extra, cwd=tmp_path)
        assert done.returncode == 2, (extra, done.stderr)
        assert message in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr
        assert not (tmp_path / "o.src").exists()


def test_program_options_are_refused_for_a_targets_csv(tmp_path):
    calibration().save(tmp_path / "cal.json")
    header = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"
    (tmp_path / "t.csv").write_text(header + "\n0,0.2,-0.2,0,0.8,0\n")
    for extra in (["--keep-failed"], ["--frames", "f.yaml"], ["--joint-targets", "correct"]):
        done = run_cli("compensate", "cal.json", "t.csv", "-o", "o.csv", *extra, cwd=tmp_path)
        assert done.returncode == 2 and "applies to robot programs" in done.stderr
        assert not (tmp_path / "o.csv").exists()
