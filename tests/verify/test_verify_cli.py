"""``calibrator verify`` on the simulated cell: before and after calibration, outputs, faults."""

import json

import numpy as np
import pandas as pd
import pytest
from cli_kit import cli, one_line_error
from verify_kit import check_outputs

from calibrator.model import rotations

SEED = "3"


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """The hidden arm of SEED, measured and identified."""
    folder = tmp_path_factory.mktemp("cell")
    done = cli("measure", "-q", "--seed", SEED, "--poses", "60", "-o", "s.parquet", cwd=folder)
    assert done.code == 0, done.stderr
    done = cli("identify", "s.parquet", "-o", "cal.json", cwd=folder)
    assert done.code == 0, done.stderr
    before = cli("verify", "-q", "--seed", SEED, "-o", "before.json", cwd=folder)
    assert before.code == 0, before.stderr
    after = cli(
        "verify", "-q", "--seed", SEED, "--calibration", "cal.json", "-o", "after.json", cwd=folder
    )
    assert after.code == 0, after.stderr
    assert "robot base frame" in after.stdout and "P5" in after.stdout
    return folder


def test_calibration_cuts_ap_tenfold_and_leaves_rp_alone(calibrated):
    folder = calibrated
    b = check_outputs(folder, "before", 30)  # 30 cycles by default
    a = check_outputs(folder, "after", 30)
    assert not b["compensated"] and a["compensated"]
    assert b["registration"]["method"] == "surveyed"
    assert a["registration"]["method"] == "calibration"
    # The same test poses, before and after.
    assert [p["commanded_mm"] for p in a["test_poses"]] == [
        p["commanded_mm"] for p in b["test_poses"]
    ]
    for pb, pa in zip(b["poses"], a["poses"], strict=True):
        assert pa["AP_mm"] <= 0.1 * pb["AP_mm"], (pb, pa)
        assert abs(pa["RP_mm"] / pb["RP_mm"] - 1) <= 0.2, (pb, pa)


def test_report_shows_before_and_after_side_by_side(calibrated):
    folder = calibrated
    done = cli(
        "report", "cal.json", "-o", "rep", "--verify", "before.json", "--verify", "after.json",
        cwd=folder,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    page = (folder / "rep" / "index.html").read_text()
    section = page[page.index('<section id="verify">') :]
    assert "before (nominal): before.json" in section and "after (compensated)" in section
    after = json.loads((folder / "after.json").read_text())
    assert f"{after['poses'][4]['AP_mm']:.4f}" in section
    assert (folder / "rep" / "verify_clouds.png").read_bytes()[:4] == b"\x89PNG"
    # Without the parquet beside it: the table stays, the plot says what is missing.
    (folder / "only").mkdir()
    (folder / "only" / "after.json").write_text((folder / "after.json").read_text())
    done = cli("report", "cal.json", "-o", "rep2", "--verify", "only/after.json", cwd=folder)
    assert done.code == 0, done.stderr
    assert "give the verify.parquet" in (folder / "rep2" / "index.html").read_text()
    assert not (folder / "rep2" / "verify_clouds.png").exists()


def test_report_refuses_a_file_that_is_not_a_verify_result(calibrated):
    folder = calibrated
    one_line_error(cli("report", "cal.json", "-o", "r3", "--verify", "cal.json", cwd=folder))
    one_line_error(cli("report", "cal.json", "-o", "r3", "--verify", "none.json", cwd=folder))
    assert not (folder / "r3").exists()


def test_before_in_the_calibration_frame_via_register(calibrated):
    folder = calibrated
    done = cli(
        "verify", "-q", "--seed", SEED, "--cycles", "3", "--register", "cal.json",
        "-o", "reg.json", cwd=folder,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    doc = check_outputs(folder, "reg", 3)
    assert doc["registration"]["method"] == "calibration" and not doc["compensated"]
    assert min(p["AP_mm"] for p in doc["poses"]) > 0.3  # the hidden errors show


def test_a_failed_visit_stops_the_certificate_and_resume_completes_it(tmp_path):
    (tmp_path / "faults.txt").write_text("MEAS@31 beam_break count=40\n")
    args = ("verify", "-q", "--cycles", "2", "--retries", "1", "-o", "v.json")
    done = cli(*args, "--tracker", "sim://?faults=faults.txt", cwd=tmp_path)
    assert done.code == 1 and "--resume" in done.stderr, done.stderr
    assert not (tmp_path / "v.json").exists() and not (tmp_path / "v.parquet").exists()
    records = (tmp_path / "v.json.journal").read_text().splitlines()[1:]
    assert [json.loads(r)["status"] for r in records].count("failed") == 1
    again = cli(*args, "--resume", cwd=tmp_path)
    assert again.code == 0, again.stderr
    check_outputs(tmp_path, "v", 2)


def test_refuses_bad_options_in_one_line(tmp_path):
    one_line_error(cli("verify", "--cube", "1,2,3", cwd=tmp_path))
    one_line_error(cli("verify", "--cube", "800,0,100,5000", "--cycles", "2", cwd=tmp_path))
    one_line_error(cli("verify", "--cycles", "1", cwd=tmp_path))
    one_line_error(cli("verify", "-o", "v.parquet", cwd=tmp_path))
    (tmp_path / "v.json").write_text("{}")
    one_line_error(cli("verify", "-o", "v.json", cwd=tmp_path))
    assert (tmp_path / "v.json").read_text() == "{}"
    one_line_error(cli("verify", "--calibration", "missing.json", "-o", "w.json", cwd=tmp_path))
    one_line_error(cli("verify", "--base-frame", "1,2,3", "-o", "w.json", cwd=tmp_path))
    one_line_error(cli("verify", "--tool", "0,0,1e308", "-o", "w.json", cwd=tmp_path))
    # A probe's kind is the simulated tracker's setting: a real tracker reports its own.
    bad = cli("verify", "--tracker", "socket://h:1?probe=6dof", "-o", "w.json", cwd=tmp_path)
    assert "unknown parameter 'probe'" in one_line_error(bad)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.json"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--readings", "1000000000"), "--readings: 1000000000 readings is more than the limit"),
        (("--settle", "1e9"), "--settle: 1e+09 s is more than the limit of 60 s"),
        (("--retries", "1000000"), "--retries: 1000000 retries is more than the limit"),
        (("--seed", "-1"), "--seed: must be a whole number >= 0"),
        (("--accel", "39"), "--accel 39.0 rad/s^2 outside (0, 2.0]"),
    ],
)
def test_the_run_options_have_measures_budgets(tmp_path, args, message):
    # The options verify shares with measure are declared once (cli/_run.py).
    assert message in one_line_error(cli("verify", *args, "-o", "w.json", cwd=tmp_path))
    assert list(tmp_path.iterdir()) == []


def test_given_cube_and_base_frame_are_used(tmp_path):
    done = cli(
        "verify", "-q", "--cycles", "2", "--cube", "700,100,300,200",
        "--base-frame", "0,0,0,0,0,0", "-o", "v.json", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    doc = check_outputs(tmp_path, "v", 2)
    assert doc["cube"] == {"centre_mm": [700.0, 100.0, 300.0], "side_mm": 200.0, "given": True}
    np.testing.assert_allclose(doc["test_poses"][0]["commanded_mm"], [700, 100, 300])
    assert doc["registration"]["method"] == "surveyed"


def test_ctrl_c_stops_after_the_current_pose_and_resume_finishes(tmp_path):
    import signal
    import time

    from cli_process_kit import run_cli, start_cli

    args = ("verify", "--cycles", "4", "--settle", "0.1", "-o", "v.json")
    proc = start_cli(*args, cwd=tmp_path)
    journal = tmp_path / "v.json.journal"
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            if journal.exists() and len(journal.read_text().splitlines()) >= 4:
                break
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1, err
    assert "stopped: interrupted before pose" in err and "Traceback" not in err
    kept = [json.loads(line)["pose"] for line in journal.read_text().splitlines()[1:]]
    assert 3 <= len(kept) < 20 and kept == list(range(len(kept)))
    assert not (tmp_path / "v.json").exists()
    again = run_cli(*args, "--resume", "-q", cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    check_outputs(tmp_path, "v", 4)


def test_a_calibration_of_another_arm_or_two_registrations_are_refused(calibrated):
    folder = calibrated
    other = cli(
        "verify", "--model", "ur5e", "--calibration", "cal.json", "-o", "x.json", cwd=folder
    )
    assert "--model ur5e but cal.json is of a ur10e" in one_line_error(other)
    both = cli(
        "verify", "--calibration", "cal.json", "--register", "cal.json", "-o", "x.json",
        cwd=folder,
    )  # fmt: skip
    assert "--calibration already registers" in one_line_error(both)
    assert not (folder / "x.json").exists() and not (folder / "x.json.journal").exists()


def test_a_six_dof_probe_gives_the_orientation_figures_of_the_true_arm(tmp_path):
    from calibrator.simulate import SimWorld

    done = cli(
        "verify",
        "-q",
        "--cycles",
        "2",
        "--tracker",
        "sim://?probe=6dof",
        "-o",
        "v.json",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    assert "APa deg" in done.stdout and "RPc deg" in done.stdout
    doc = json.loads((tmp_path / "v.json").read_text())
    assert doc["orientation"].startswith("measured")
    table = pd.read_parquet(tmp_path / "v.parquet")
    # What the hidden arm really does at the commanded joints, seen in the base frame.
    world = SimWorld.make("ur10e", 0)
    q = np.array([p["q_rad"] for p in doc["test_poses"]])
    attained = np.stack([world.tool_pose(qk)[:3, :3] for qk in q])
    true_angles = rotations.angles_xyz(world.base2tracker[:3, :3].T @ attained)
    commanded = rotations.angles_xyz(np.array([p["rotation"] for p in doc["test_poses"]]))
    for p, truth, cmd in zip(doc["poses"], true_angles, commanded, strict=True):
        rows = table[table["test_pose"] == p["test_pose"]]
        # The poses face the tracker, so b is far from 0: a and c take the
        # probe's noise amplified by 1 / cos(b) (the x-y-z angles near their
        # singularity at b = 90 deg); b takes it as it is.
        gain = np.array([1.0 / np.cos(cmd[1]), 1.0, 1.0 / np.cos(cmd[1])])
        for k, axis in enumerate("abc"):
            values = rows[f"{axis}_rad"].to_numpy()
            # RP from the table (3 S, ISO 9283), AP against the true arm (survey, noise: < 5 mdeg)
            assert p[f"RP{axis}_deg"] == pytest.approx(3 * np.degrees(values.std(ddof=1)), abs=1e-9)
            assert p[f"AP{axis}_deg"] == pytest.approx(
                np.degrees(truth[k] - cmd[k]), abs=5e-3 * abs(gain[k])
            )
        assert max(abs(p[f"AP{axis}_deg"]) for axis in "abc") > 0.02  # the hidden errors show
