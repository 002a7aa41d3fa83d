"""``verify --path --robot external`` end to end: a generated path program played by the player.

``calibrator program --path`` writes the circle (KRL) or the line (RAPID);
the external-robot simulator plays it on a hidden true arm (its nominal
controller solving the program's targets, the true arm running the joints)
and moves a tracker simulator's target along the true path on the tracker's
own clock, with a latency; ``calibrator verify --path --robot external``
streams the tracker without knowing when the program starts, finds the
cycles and aligns them with the commanded path from the program's speed.

The figures are checked against the hidden arm: AT_P against the true
path's deviation from the commanded one, computed here from the truth
(nominal inverse kinematics of the commanded path, true forward kinematics),
RT_P and AV against a program that repeats itself exactly at its stated speed.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from cli_process_kit import child_env, run_cli, start_cli
from timeout_kit import readline

from calibrator import robots
from calibrator.model import frames, kinematics, rotations
from calibrator.verify import iso9283, pose
from calibrator.verify import path as verify_path

#: Simulated seconds per wall-clock second of the tracker simulator (500 Hz stream: 1000 frames/s).
TIME_SCALE = 2
#: The tracker's stamps are this late for a moving target, s: the alignment absorbs it.
LATENCY_S = 0.02
SPEED = 200
CYCLES = 3


@contextmanager
def tracker_simulator(seed: int = 2):
    """A line-protocol tracker simulator on TCP (time-scaled, with latency); yields its URL."""
    proc = subprocess.Popen(
        [
            sys.executable, "-m", "drivers.tracker.line.simulator", "--tcp", "0",
            "--initialised", "--seed", str(seed), "--time-scale", str(TIME_SCALE),
            "--latency", str(LATENCY_S),
        ],
        stdout=subprocess.PIPE, text=True, env=child_env(None),
    )  # fmt: skip
    try:
        port = readline(proc.stdout, what="the simulator's port").strip()
        assert port.isdigit(), port
        yield f"socket://127.0.0.1:{port}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        proc.stdout.close()


def _base_frame(truth: dict) -> str:
    """The true base placement as ``--base-frame X,Y,Z,RX,RY,RZ`` (a surveyed base)."""
    b = np.array(truth["base2tracker"])
    values = [*b[:3, 3], *rotations.matrix_to_rotvec(b[:3, :3])]
    return ",".join(f"{v:.9f}" for v in values)


def expected_at_p(truth: dict, shape: str) -> float:
    """AT_P of the hidden arm, computed from the truth alone (no stream, no player).

    The commanded path's points (verify's cube and tool), the nominal arm's
    joints there, the true arm's reflector at those joints in the base frame:
    the largest deviation across the path's direction (within the normal
    plane, as ISO 9283 measures it), over the calculated points.
    """
    arm = robots.get("ur10e")
    tool = frames.transform(translation=(0.0, 0.0, 100.0))
    vplan = pose.make_plan(arm, tool, 2)
    rotation = vplan.desired[0][:3, :3]
    path = verify_path.test_path(shape, vplan.cube, rotation)
    s = verify_path.ip.calculated_points(path, verify_path.POINTS)
    commanded = path.point(s)
    q = iso9283.solve_poses(
        arm.mdh, frames.transform(rotation, commanded), tool, arm.joint_limits_rad,
        vplan.q_test[0],
    ).q  # fmt: skip
    true_flange2tool = np.array(truth["flange2tool"])
    base2tracker = np.array(truth["base2tracker"])
    in_tracker = kinematics.forward(np.array(truth["true_mdh"]), q, true_flange2tool, base2tracker)
    # Into the base frame: p_base = R^T (p_tracker - t).
    attained = (in_tracker[:, :3, 3] - base2tracker[:3, 3]) @ base2tracker[:3, :3]
    d = attained - commanded
    tangent = path.tangent(s)
    across = d - np.sum(d * tangent, axis=1, keepdims=True) * tangent
    return float(np.linalg.norm(across, axis=1).max())


def _run(
    tmp_path: Path, shape: str, program: str, calibration: str | None = None
) -> tuple[dict, dict, str]:
    """Program, player and verify for ``shape`` as ``program``: verify.json, truth, stdout."""
    done = run_cli(
        "program", "--path", shape, "-o", program, "--path-speed", str(SPEED),
        "--cycles", str(CYCLES), "--dwell", "1",
        *(["--calibration", calibration] if calibration else []), cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert f"--path-speed {SPEED} --cycles {CYCLES}" in done.stdout
    with tracker_simulator() as url:
        player = subprocess.Popen(
            [
                sys.executable, "-m", "drivers.robot.external_sim", "--program", program,
                "--control", url, "--model", "ur10e", "--seed", "3", "--time-scale",
                str(TIME_SCALE), "--truth", "truth.json", "--wait-start",
            ],
            cwd=tmp_path, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, env=child_env(None),
        )  # fmt: skip
        try:
            assert readline(player.stdout, timeout_s=120, what="'ready'").strip() == "ready", (
                player.stderr.read() if player.poll() is not None else ""
            )
            truth = json.loads((tmp_path / "truth.json").read_text())
            verify = start_cli(
                "verify", "--path", shape, "--path-speed", str(SPEED), "--cycles",
                str(CYCLES), "--robot", "external", "--tracker", url,
                *(["--calibration", calibration] if calibration else
                  ["--base-frame", _base_frame(truth)]),
                "-o", "path.json", cwd=tmp_path,
            )  # fmt: skip
            err: list[str] = []
            cue = threading.Event()

            def drain() -> None:
                for line in verify.stderr:
                    err.append(line)
                    if "start the path program now" in line:
                        cue.set()
                cue.set()

            reader = threading.Thread(target=drain, daemon=True)
            reader.start()
            assert cue.wait(180), "verify never streamed"
            player.stdin.write("\n")  # the operator presses start
            player.stdin.close()
            code = verify.wait(timeout=240)
            reader.join(timeout=10)
            out = verify.stdout.read()
            verify.stdout.close()
            assert code == 0, "".join(err) + out
            assert player.wait(timeout=60) == 0, player.stderr.read()
        finally:
            if player.poll() is None:
                player.kill()
                player.wait(timeout=10)
            player.stdout.close()
            player.stderr.close()
    return json.loads((tmp_path / "path.json").read_text()), truth, out


@pytest.mark.timeout(600)
def test_krl_circle_played_by_the_player_gives_the_hidden_arms_path_figures(tmp_path):
    doc, truth, out = _run(tmp_path, "circle", "circle.src")
    section = doc["path"]
    assert section["shape"] == "circle" and section["cycles"] == CYCLES
    assert section["alignment"] == "tracker only, from the programmed path"
    assert doc["robot"] == "external:ur10e"
    expected = expected_at_p(truth, "circle")
    # The uncalibrated arm misses the circle by a fraction of a mm up to mm: the stream says so.
    assert expected > 0.1
    assert section["AT_P_mm"] == pytest.approx(expected, abs=0.03)
    # The program runs the same path every cycle: only the tracker's noise spreads it (3 S of
    # three crossings: 0.045-0.059 mm on the simulated cell's own path test, docs/verify.md).
    assert section["RT_P_mm"] < 0.1
    # At the stated speed: the program's $VEL.CP, read by the controller.
    assert abs(section["AV_pct"]) < 1.0
    assert "AT_P" in out
    print(
        f"\ncircle: AT_P {section['AT_P_mm']:.4f} mm (truth {expected:.4f}), "
        f"RT_P {section['RT_P_mm']:.4f}, AV {section['AV_pct']:+.3f} %, "
        f"FV {section['FV_mm_s']:.3f}, starts {section['start_s']}"
    )


@pytest.mark.timeout(600)
def test_rapid_line_with_its_way_back_gives_the_line_figures_of_its_runs_only(tmp_path):
    doc, truth, _ = _run(tmp_path, "line", "line.mod")
    section = doc["path"]
    assert section["shape"] == "line" and section["cycles"] == CYCLES
    expected = expected_at_p(truth, "line")
    assert expected > 0.1
    # The way back P4 -> P2 is not a cycle: taken as one it would spoil AT_P and AV.
    assert section["AT_P_mm"] == pytest.approx(expected, abs=0.03)
    assert section["RT_P_mm"] < 0.1
    assert abs(section["AV_pct"]) < 1.0
    streams = pd.read_parquet(tmp_path / "path.parquet")
    assert sorted(streams["cycle"].unique()) == list(range(1, CYCLES + 1))
    print(
        f"\nline: AT_P {section['AT_P_mm']:.4f} mm (truth {expected:.4f}), "
        f"RT_P {section['RT_P_mm']:.4f}, AV {section['AV_pct']:+.3f} %, "
        f"FV {section['FV_mm_s']:.3f}, starts {section['start_s']}"
    )


@pytest.mark.timeout(900)
def test_a_compensated_circle_program_cuts_the_hidden_arms_path_error(tmp_path):
    # A calibration of the hidden arm: the simulated cell of the same seed is the player's arm.
    for args in (
        ("measure", "-q", "--seed", "3", "--poses", "60", "-o", "s.parquet"),
        ("identify", "s.parquet", "-o", "cal.json"),
    ):
        done = run_cli(*args, cwd=tmp_path)
        assert done.returncode == 0, done.stderr
    doc, truth, out = _run(tmp_path, "circle", "circle.src", calibration="cal.json")
    section = doc["path"]
    assert section["compensated"] is True and "compensated commands" in out
    before = expected_at_p(truth, "circle")
    # From 1.5 mm (the nominal program, above) to a few hundredths: the correction's own
    # residual, the arcs' interpolation of it and the tracker's noise.
    assert section["AT_P_mm"] < 0.05 < before
    assert section["RT_P_mm"] < 0.1 and abs(section["AV_pct"]) < 1.0
    print(
        f"\ncompensated circle: AT_P {section['AT_P_mm']:.4f} mm (nominal {before:.4f}), "
        f"RT_P {section['RT_P_mm']:.4f}, AV {section['AV_pct']:+.3f} %"
    )


@pytest.mark.timeout(600)
def test_urscript_rectangle_with_exact_stops_at_its_corners_is_one_cycle_each_run(tmp_path):
    doc, truth, out = _run(tmp_path, "rectangle", "rect.script")
    section = doc["path"]
    assert section["shape"] == "rectangle" and section["cycles"] == CYCLES
    # The stops at the corners join the sides into one cycle: the runs are the cycles.
    streams = pd.read_parquet(tmp_path / "path.parquet")
    assert sorted(streams["cycle"].unique()) == list(range(1, CYCLES + 1))
    expected = expected_at_p(truth, "rectangle")
    assert section["AT_P_mm"] == pytest.approx(expected, abs=0.03)
    assert len(section["CR_mm"]) == len(section["CO_mm"]) == 3
    assert "corners, mm" in out
    print(
        f"\nrectangle: AT_P {section['AT_P_mm']:.4f} mm (truth {expected:.4f}), "
        f"RT_P {section['RT_P_mm']:.4f}, AV {section['AV_pct']:+.3f} %, "
        f"CR {section['CR_mm']}, CO {section['CO_mm']}"
    )
