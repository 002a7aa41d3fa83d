"""The quick circle test: its figures from circles of known faults, and a crash it flags."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator.check import circle as circles
from calibrator.verify import path_figures as ip

R = 100.0
OFFSET = 0.15  # mm, centre moved along the start direction
RADIUS_ERROR = 0.02  # mm
STEP = 0.08  # mm, a reversal mark planted where joint 1 reverses
A0 = np.radians(90.0)  # where joint 1 reverses (and again half a turn on)


def _run(direction: str, step: float) -> circles.Run:
    ccw = ip.circle([500.0, 0, 300], [0, 0, 1], R, [1, 0, 0])
    path = ccw if direction == "counter-clockwise" else circles.reversed_circle(ccw)
    t = np.linspace(0.0, 2 * np.pi, 3601)  # 1 s per radian: the speed is R mm/s
    p = path.point(R * t)
    angle = np.mod(np.arctan2(p[:, 1], p[:, 0] - 500.0), 2 * np.pi)
    # The attained path: bigger by RADIUS_ERROR, shifted by OFFSET, and STEP further out
    # on the half turn after joint 1 reverses at A0 (as a backlash would push it).
    dr = RADIUS_ERROR + step * (np.mod(angle - A0, 2 * np.pi) < np.pi)
    radial = np.column_stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)])
    attained = p + dr[:, None] * radial + [OFFSET, 0.0, 0.0]
    q = np.zeros((len(t), 6))
    q[:, 0] = -np.cos(angle - A0)  # turns one way, then back at A0 and A0 + pi
    q[:, 1] = 0.3 * t  # a joint that never reverses
    return circles.Run(direction, path, t, q, ip.Stream(t, attained))


def test_a_shifted_bigger_circle_gives_its_radius_error_and_centre_offset():
    fig = circles.figures([_run(d, 0.0) for d in circles.DIRECTIONS])
    assert fig["radius_error_mm"] == pytest.approx(RADIUS_ERROR, abs=2e-4)
    assert fig["centre_offset_norm_mm"] == pytest.approx(OFFSET, abs=1e-3)
    assert fig["centre_offset_mm"][0] == pytest.approx(OFFSET, abs=1e-3)
    # A fixed-centre ballbar reads a shifted circle as out of round by twice the shift.
    assert fig["out_of_roundness_mm"] == pytest.approx(2 * OFFSET, abs=1e-3)
    assert fig["reversal_mm"] < 1e-3 and fig["direction_gap_mm"] < 1e-3
    assert fig["verdict"] == "flagged" and fig["exceeded"] == ["out_of_roundness_mm"]


def test_a_step_where_a_joint_reverses_is_a_reversal_mark_of_its_height():
    fig = circles.figures([_run("clockwise", 0.0), _run("counter-clockwise", STEP)])
    marks = [m for m in fig["marks"] if m["direction"] == "counter-clockwise"]
    assert {m["joint"] for m in fig["marks"]} == {1}  # joint 2 never reverses
    assert sorted(round(m["angle_deg"]) for m in marks) == [90, 270]
    assert fig["reversal_mm"] == pytest.approx(STEP, rel=0.1)
    assert fig["direction_gap_mm"] == pytest.approx(STEP, abs=1e-3)
    assert "reversal_mm" in fig["exceeded"]


def test_a_true_circle_is_ok():
    ccw = ip.circle([0, 0, 0], [0, 0, 1], R, [1, 0, 0])
    runs = []
    for direction in circles.DIRECTIONS:
        path = ccw if direction == "counter-clockwise" else circles.reversed_circle(ccw)
        t = np.linspace(0, 2 * np.pi, 2001)
        q = np.zeros((len(t), 6))
        runs.append(circles.Run(direction, path, t, q, ip.Stream(t, path.point(R * t))))
    fig = circles.figures(runs)
    assert fig["verdict"] == "ok" and fig["out_of_roundness_mm"] < 1e-6


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """Seed 3's arm as it is, measured and identified; its crashed twin (joint 2's zero)."""
    folder = tmp_path_factory.mktemp("circle")
    (folder / "today.yaml").write_text("world: 1\nmodel: ur10e\nseed: 3\n")
    (folder / "crashed.yaml").write_text(
        "world: 1\nmodel: ur10e\nseed: 3\njoint_zero_shifts_rad: [0, 4.0e-4, 0, 0, 0, 0]\n"
    )
    done = cli(
        "measure", "--model", "ur10e", "--world", "today.yaml", "--poses", "40",
        "-o", "cal.parquet", "-q", cwd=folder,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    done = cli("identify", "cal.parquet", "-o", "cal.json", cwd=folder)
    assert done.code == 0, done.stderr
    return folder


def test_the_circle_test_flags_a_joint_zero_crash_and_passes_the_sound_arm(calibrated):
    runs = {}
    for world, code in (("today", 0), ("crashed", 3)):
        done = cli(
            "check", "--circle", "--model", "ur10e", "--calibration", "cal.json",
            "--world", f"{world}.yaml", "-o", f"{world}.json", cwd=calibrated,
        )  # fmt: skip
        assert done.code == code, (done.stdout, done.stderr)
        runs[world] = json.loads((calibrated / f"{world}.json").read_text())["circle"]
    today, crashed = runs["today"], runs["crashed"]
    limits = circles.LIMITS_MM
    assert today["verdict"] == "ok"
    for key, limit in limits.items():
        assert abs(today[key]) < limit / 3, (key, today[key])
    # Joint 2 turned 0.4 mrad about 0.8 m from the tool moves the circle by about 0.3 mm:
    # the fixed-centre out-of-roundness reads twice that, far beyond its limit.
    assert crashed["verdict"] == "flagged" and "out_of_roundness_mm" in crashed["exceeded"]
    assert crashed["out_of_roundness_mm"] > 3 * limits["out_of_roundness_mm"]
    assert crashed["centre_offset_norm_mm"] > 0.2
    assert {m["direction"] for m in crashed["marks"]} == set(circles.DIRECTIONS)


@pytest.mark.parametrize(
    "args, message",
    [
        (("--tracker", "socket://127.0.0.1:9"), "--circle runs on the simulated cell only"),
        (("--circle-speed", "0"), "--circle-speed must be in"),
        (("--session", "s.parquet"), "leave out --session"),
    ],
)
def test_circle_options_it_cannot_run_are_refused_in_one_line(calibrated, args, message):
    done = cli(
        "check", "--circle", "--calibration", "cal.json", *args, "-o", "x.json", cwd=calibrated
    )
    assert message in one_line_error(done)
    assert not (calibrated / "x.json").exists()
