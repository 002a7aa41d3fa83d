"""``calibrator measure`` run in-process on the simulated cell, so mutation testing sees it.

The end-to-end tests (test_measure_*.py) run the command in a new process,
which imports the unmutated package. Here the same command runs through
``main()`` (tests/cli_kit.py): the session is checked against the
simulated arm's hidden truth, the journal and ``--resume`` against a clean
run, and every refusal is one line with exit 2 that leaves nothing behind.
Noise-free, with 3 readings per pose, so a run takes about a second.
"""

import json
import os
import re
import signal
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import typer
from cli_kit import cli, one_line_error
from measure_kit import session_rows

from calibrator import cell as cells
from calibrator import planning, robots, session
from calibrator.cli import _run
from calibrator.model import frames
from calibrator.simulate import SIM_TRACKER_AT_MM, SimWorld
from drivers.robot.sim.device import SimulatedRobot
from drivers.tracker import read_log

UR10E = robots.get("ur10e")
#: The simulated tracker reading exactly (its settings in its URL).
NO_NOISE = "sim://?noise=off"
FAST = (
    "--poses",
    "10",
    "--readings",
    "3",
    "--tracker",
    "sim://?noise=off",
    "-q",
    "-o",
    "s.parquet",
)
SIM_IDENTITY = "CALIBRATOR:TRACKER-SIM:SIM-0001"  # what the tracker simulator says it is


def measure(*args, cwd):
    return cli("measure", *args, cwd=cwd)


def expected_plan(seed=0, tool=(0.0, 0.0, 100.0), tracker_at=SIM_TRACKER_AT_MM, n=10):
    """The plan ``measure --poses n`` makes: the checked planner of ``calibrator plan``."""
    cell = cells.Cell(tracker_at_mm=tuple(float(v) for v in tracker_at))
    return planning.make_checked(UR10E, n, cell, tool, seed=seed).plan.q_rad


def table(path):
    return pq.read_table(path).to_pydict()


def progress_lines(stderr):
    return [line for line in stderr.splitlines() if line.startswith("progress ")]


def test_session_holds_the_simulated_arm_pose_for_pose(tmp_path):
    tool = (1.0, -2.0, 105.0)
    done = measure(
        *FAST[:-3],  # with progress lines
        "-o",
        "s.parquet",
        "--seed",
        "2",
        "--tool",
        "1,-2,105",
        "--speed",
        "1.0",  # the cap itself is allowed
        "--timings",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    assert done.stdout == "wrote s.parquet: 10 poses x 3 readings\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.parquet"]  # journal gone

    q_plan = expected_plan(seed=2, tool=tool)
    rows = table(tmp_path / "s.parquet")
    assert rows["pose"] == list(range(10)) and set(rows["n_readings"]) == {3}
    q = np.column_stack([rows[f"q{i}_rad"] for i in range(1, 7)])
    np.testing.assert_allclose(q, q_plan, atol=1e-12)
    truth = SimWorld.make("ur10e", 2)
    points = np.column_stack([rows[c] for c in ("x_mm", "y_mm", "z_mm")])
    expected = np.array([truth.tool_pose(qi)[:3, 3] for qi in q_plan])
    np.testing.assert_allclose(points, expected, atol=1e-4)  # the tracker's 0.1 um
    spread = np.column_stack([rows[c] for c in ("sx_mm", "sy_mm", "sz_mm")])
    assert np.all(spread < 1e-6)

    meta = session.load(tmp_path / "s.parquet").meta
    assert (meta.frame, meta.model, meta.tool_known) == ("tracker", "ur10e", False)
    np.testing.assert_array_equal(meta.nominal_mdh, UR10E.mdh)
    np.testing.assert_array_equal(meta.flange2tool, frames.transform(translation=tool))
    assert meta.extra["measured"] == {
        "robot": "sim:ur10e:seed=2",
        "tracker": SIM_IDENTITY,
        "plan_sha256": planning.digest(q_plan),  # what a resume checks an existing file against
        "description": {"name": "ur10e", "sha256": UR10E.digest},  # which arm, exactly
    }

    lines = progress_lines(done.stderr)
    assert [re.search(r" pose=(\d+) ", x).group(1) for x in lines] == [str(i) for i in range(10)]
    assert [re.search(r" done=(\d+) ", x).group(1) for x in lines] == [str(i) for i in range(1, 11)]
    timing = [x.split(":")[1].strip() for x in done.stderr.splitlines() if x.startswith("timing")]
    assert timing == [
        "connect (simulator start, links)",
        "plan (make and check)",
        "measure loop",
        "write session",
        "close (devices, simulator)",
    ]


def test_progress_reports_each_pose_spread_in_micrometres(tmp_path):
    done = measure(*FAST[:2], "--readings", "4", "-o", "s.parquet", cwd=tmp_path)  # with noise
    assert done.code == 0, done.stderr
    rows = table(tmp_path / "s.parquet")
    spread_um = 1e3 * np.linalg.norm(
        np.column_stack([rows[c] for c in ("sx_mm", "sy_mm", "sz_mm")]), axis=1
    )
    shown = [float(re.search(r"spread_um=(\S+)", x).group(1)) for x in progress_lines(done.stderr)]
    assert len(shown) == 10 and min(shown) > 0.1  # a noisy tracker: tenths of um at least
    np.testing.assert_allclose(shown, spread_um, rtol=1e-3)
    assert "timing" not in done.stderr


def test_tracker_at_places_the_plan_and_a_plan_file_is_measured_as_written(tmp_path):
    at = (300.0, 2500.0, 500.0)
    done = measure(*FAST, "--tracker-at", "300,2500,500", cwd=tmp_path)
    assert done.code == 0, done.stderr
    rows = session_rows(tmp_path / "s.parquet")
    np.testing.assert_allclose(
        np.array([rows[i][0] for i in range(10)]), expected_plan(tracker_at=at), atol=1e-12
    )
    own = expected_plan(seed=5)[::-1]
    planning.write_plan(tmp_path / "plan.csv", planning.Plan(own))
    done = measure(*FAST[2:-2], "--plan", "plan.csv", "-o", "p.parquet", cwd=tmp_path)
    assert done.code == 0, done.stderr
    rows = session_rows(tmp_path / "p.parquet")
    np.testing.assert_allclose(np.array([rows[i][0] for i in range(10)]), own, atol=1e-12)


def journal_lines(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_failed_pose_keeps_the_journal_and_resume_retries_only_it(tmp_path):
    # Readings 1-9 are poses 0-2; the beam breaks on both tries of pose 3 (retries 1).
    (tmp_path / "faults.txt").write_text("MEAS@10 beam_break count=2\n")
    done = measure(
        *FAST, "--retries", "1", "--tracker", NO_NOISE + "&faults=faults.txt", cwd=tmp_path
    )
    assert done.code == 0, done.stderr
    assert done.stdout == (
        "1 pose(s) failed: beam broken x2 (after 1 retries: poses [3]); wrote s.parquet with "
        "9 poses; rerun the same command with --resume to continue (s.parquet.journal) to "
        "retry them\n"
    )
    assert sorted(session_rows(tmp_path / "s.parquet")) == [0, 1, 2, 4, 5, 6, 7, 8, 9]
    header, *records = journal_lines(tmp_path / "s.parquet.journal")
    q_plan = expected_plan()
    assert header["plan_sha256"] == planning.digest(q_plan)
    assert (header["robot"], header["tracker"]) == ("sim:ur10e:seed=0", SIM_IDENTITY)
    assert (header["readings"], header["poses"]) == (3, 10)
    assert header["meta"] == session.load(tmp_path / "s.parquet").meta.to_json()
    failed = [r for r in records if r["status"] == "failed"]
    assert [(r["pose"], r["attempts"]) for r in failed] == [(3, 2)]

    # The reading count is part of the run's identity: another one is refused, nothing changes.
    before = (tmp_path / "s.parquet.journal").read_bytes()
    refused = measure(*FAST[:2], "--readings", "4", *FAST[4:], "--resume", cwd=tmp_path)
    assert "belongs to another run: its readings is 3" in one_line_error(refused)
    assert (tmp_path / "s.parquet.journal").read_bytes() == before

    again = measure(*FAST, "--resume", cwd=tmp_path)
    assert again.code == 0, again.stderr
    assert again.stdout == "wrote s.parquet: 10 poses x 3 readings\n"
    assert not (tmp_path / "s.parquet.journal").exists()
    rows = session_rows(tmp_path / "s.parquet")
    assert sorted(rows) == list(range(10))
    truth = SimWorld.make("ur10e", 0)
    np.testing.assert_allclose(rows[3][1], truth.tool_pose(q_plan[3])[:3, 3], atol=1e-4)


def test_progress_marks_a_failed_pose(tmp_path):
    (tmp_path / "faults.txt").write_text("MEAS@10 beam_break count=1\n")
    done = measure(
        *FAST[:-3],
        "-o",
        "s.parquet",
        "--retries",
        "0",
        "--tracker",
        NO_NOISE + "&faults=faults.txt",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    spreads = [re.search(r"spread_um=(\S+)", x).group(1) for x in progress_lines(done.stderr)]
    assert spreads[3] == "FAILED" and spreads.count("FAILED") == 1
    assert " pose=3 spread_um=FAILED" in progress_lines(done.stderr)[3]
    assert "failed: beam broken x1 (after 0 retries: poses [3])" in done.stdout


def measured_poses_moved_to(plan):
    """Which moves of the simulated robot go to a pose of ``plan`` (N, 6) (not a via)."""
    return lambda q: bool(np.all(plan == np.asarray(q), axis=1).any())


def test_a_made_plan_is_moved_along_whole_vias_included(tmp_path, monkeypatch):
    move = SimulatedRobot.move_joints
    moves = []

    def recorded(self, q, speed, accel):
        moves.append(np.array(q, dtype=float))
        return move(self, q, speed, accel)

    monkeypatch.setattr(SimulatedRobot, "move_joints", recorded)
    done = measure(*FAST, cwd=tmp_path)
    assert done.code == 0, done.stderr
    cell = cells.Cell(tracker_at_mm=tuple(float(v) for v in SIM_TRACKER_AT_MM))
    made = planning.make_checked(UR10E, 10, cell, (0.0, 0.0, 100.0), seed=0).plan
    assert made.n_vias  # the moves the cell check passed only through vias
    np.testing.assert_array_equal(np.array(moves), made.path_rad)


def test_ctrl_c_stops_after_the_current_pose_then_resume_finishes(tmp_path, monkeypatch):
    move = SimulatedRobot.move_joints
    is_pose = measured_poses_moved_to(expected_plan())
    moves = []  # moves to measured poses (vias are moved through on the way)

    def ctrl_c_during_pose_3(self, q, speed, accel):
        if is_pose(q):
            if len(moves) == 3:
                os.kill(os.getpid(), signal.SIGINT)
            moves.append(q)
        return move(self, q, speed, accel)

    monkeypatch.setattr(SimulatedRobot, "move_joints", ctrl_c_during_pose_3)
    done = measure(*FAST, cwd=tmp_path)
    assert done.code == 1
    assert done.stderr.strip().splitlines() == [
        "stopping after the current pose (Ctrl-C again to abort now)",
        "stopped: interrupted before pose 4; 4 of 10 poses kept; rerun the same command with "
        "--resume to continue (s.parquet.journal)",
    ]
    assert sorted(session_rows(tmp_path / "s.parquet")) == [0, 1, 2, 3]
    assert len(moves) == 4  # the arm went no further than the pose it was measuring
    monkeypatch.undo()
    again = measure(*FAST, "--resume", cwd=tmp_path)
    assert again.code == 0, again.stderr
    assert sorted(session_rows(tmp_path / "s.parquet")) == list(range(10))


def test_a_halted_robot_stops_the_run_with_the_operators_next_steps(tmp_path, monkeypatch):
    move = SimulatedRobot.move_joints
    is_pose = measured_poses_moved_to(expected_plan())
    moves = []  # moves to measured poses

    def trips_at_pose_4(self, q, speed, accel):  # the arm's safety system trips at pose 4
        if is_pose(q):
            if len(moves) == 4:
                self.inject_protective_stop()
            moves.append(q)
        return move(self, q, speed, accel)

    monkeypatch.setattr(SimulatedRobot, "move_joints", trips_at_pose_4)
    done = measure(*FAST, cwd=tmp_path)
    assert done.code == 1
    message = done.stderr.strip()
    assert message.startswith("stopped: robot halted at pose 4: ")
    assert (
        "; 4 of 10 poses kept; clear the stop on the pendant (after an e-stop: release it, "
        "power on and release the brakes), then rerun the same command with --resume"
    ) in message
    assert sorted(session_rows(tmp_path / "s.parquet")) == [0, 1, 2, 3]


def write_plans(folder):
    q = expected_plan()[:10].copy()  # distinct poses: a repeated pose is refused first
    bad = q.copy()
    bad[6, 2] = 4.0  # the elbow beyond its limit, in the 7th row
    planning.write_plan(folder / "bad.csv", planning.Plan(bad))
    planning.write_plan(folder / "short.csv", planning.Plan(q[:3]))
    (folder / "s.parquet.old").write_text("")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ("--speed", "1.5"),
            "--speed 1.5 rad/s outside (0, 1.0] (the ur10e ceiling or --max-speed)",
        ),
        (
            ("--speed", "0.5", "--max-speed", "0.4"),
            "--speed 0.5 rad/s outside (0, 0.4] (the ur10e ceiling or --max-speed)",
        ),
        (
            ("--max-speed", "1.5"),
            "--max-speed 1.5 rad/s above the ur10e ceiling 1.0 rad/s: it can lower the cap",
        ),
        (("--accel", "39"), "--accel 39.0 rad/s^2 outside (0, 2.0] (the ur10e ceiling;"),
        (("--accel", "1000", "--robot", "ur://127.0.0.1"), "--accel 1000.0 rad/s^2 outside"),
        (("--model", "ur5x"), "unknown model 'ur5x'"),
        (("--tool", "1,2"), "--tool: needs X,Y,Z (three numbers, mm), got '1,2'"),
        (("--tool", "1,2,inf"), "--tool: 'inf' is not a decimal number"),
        (("--tool", "1,x,3"), "--tool: 'x' is not a decimal number"),
        (
            ("--tracker-at", "1,2,3,4"),
            "--tracker-at: needs X,Y,Z (three numbers, mm), got '1,2,3,4'",
        ),
        (("--tool", "0,0,1e308"), "--tool: 1e+308 mm is beyond +-2000 mm"),
        (("--readings", "1000000000"), "--readings: 1000000000 readings is more than the limit"),
        (("--settle", "1e9"), "--settle: 1e+09 s is more than the limit of 60 s"),
        (("--tracker", "sim://?faults=none.txt"), "file not found: none.txt"),
        (("--tracker", "sim://?replay=none.jsonl"), "file not found: none.jsonl"),
        (("--resume",), "nothing to resume: s.parquet.journal not found"),
        (("--robot", "ftp://x"), "--robot: unknown robot 'ftp://x'; use sim or ur://HOST"),
        (
            ("--tracker", "gopher://x"),
            "--tracker: unknown tracker 'gopher://x'; use sim or a device path or "
            "socket://HOST:PORT or rfc2217://HOST:PORT or loop:// or emscon://HOST[:PORT]",
        ),
        (("--robot", "ur://"), "--robot: 'ur://': missing host (use ur://HOST)"),
        (("--plan", "bad.csv"), "plan row 6 joint 3: 4 rad outside"),
        (("--tracker", "socket://127.0.0.1:1"), "tracker at socket://127.0.0.1:1: "),
        (
            ("--tracker", "emscon://127.0.0.1:1?meteo=20,1013"),
            "--tracker: 'emscon://127.0.0.1:1?meteo=20,1013': meteo needs T,P,H",
        ),
    ],
)
def test_bad_input_is_one_line_exit_2_and_leaves_nothing(tmp_path, args, message):
    write_plans(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    done = measure(*FAST, *args, cwd=tmp_path)
    assert message in one_line_error(done)
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_the_shortfall_names_the_models_own_minimum(tmp_path):
    write_plans(tmp_path)
    done = measure(*FAST, "--plan", "short.csv", cwd=tmp_path)
    need = planning.min_poses(UR10E.mdh)
    assert one_line_error(done).endswith(
        f"plan has 3 poses; the free parameters need at least {need}"
    )


@pytest.mark.parametrize(
    ("existing", "args", "message"),
    [
        (
            "s.parquet",
            (),
            "s.parquet exists: remove it, choose another -o, pass --force to replace it, "
            "or --resume to continue its run",
        ),
        (
            "s.parquet.journal",
            (),
            "s.parquet.journal exists (an unfinished run): pass --resume to continue it, "
            "or remove it",
        ),
        ("plan.csv", ("--plan", "plan.csv", "-o", "plan.csv"), "plan.csv"),
    ],
)
def test_nothing_is_replaced(tmp_path, existing, args, message):
    (tmp_path / existing).write_text("precious\n")
    done = measure(*FAST, *args, cwd=tmp_path)
    assert message in one_line_error(done)
    assert [p.name for p in tmp_path.iterdir()] == [existing]
    assert (tmp_path / existing).read_text() == "precious\n"


def test_a_real_robot_needs_a_confirmation_from_a_terminal(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdin", open(os.devnull))  # not a terminal
    with pytest.raises(typer.Exit) as exc:
        _run.confirm("ur://10.0.0.5:ur10e", 12)
    assert exc.value.exit_code == 2
    assert capsys.readouterr().err == (
        "calibrator: error: the robot ur://10.0.0.5:ur10e would move through 12 poses: "
        "pass --yes to confirm\n"
    )


@pytest.mark.parametrize(("answer", "moves"), [("n\n", False), ("y\n", True), ("\n", False)])
def test_the_confirmation_question_defaults_to_no(monkeypatch, capsys, answer, moves):
    class Terminal:
        def isatty(self):
            return True

    monkeypatch.setattr(sys, "stdin", Terminal())
    asked = []

    def confirm(text, default):
        asked.append((text, default))
        return {"y\n": True, "n\n": False}.get(answer, default)

    monkeypatch.setattr(typer, "confirm", confirm)
    if moves:
        _run.confirm("ur://h:ur10e", 3)
    else:
        with pytest.raises(typer.Exit) as exc:
            _run.confirm("ur://h:ur10e", 3)
        assert exc.value.exit_code == 2
        assert capsys.readouterr().err == "calibrator: error: not confirmed; nothing moved\n"
    assert asked == [("Move the robot ur://h:ur10e through 3 poses?", False)]


def test_first_ctrl_c_asks_for_a_stop_the_second_interrupts(capsys):
    previous = signal.getsignal(signal.SIGINT)
    with _run.StopOnSigint() as stop:
        assert stop.requested is False
        os.kill(os.getpid(), signal.SIGINT)
        assert stop.requested is True
        assert "stopping after the current pose" in capsys.readouterr().err
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is previous


def test_a_replayed_exchange_gives_the_recorded_session_and_is_recorded_again(tmp_path):
    fixtures = Path(__file__).resolve().parents[2] / "fixtures" / "measure"
    from test_measure_replay import fixture_plan

    done = measure(
        "--plan", fixture_plan(tmp_path), "--readings", "5", "-q", "-o", "s.parquet",
        "--tracker", f"{NO_NOISE}&replay={fixtures / 'exchange.jsonl'}&record=again.jsonl",
        cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    replayed, recorded = table(tmp_path / "s.parquet"), table(fixtures / "session.parquet")
    for column in ("pose", "q1_rad", "q6_rad", "x_mm", "y_mm", "z_mm", "sx_mm", "n_readings"):
        assert replayed[column] == recorded[column], column
    sent = [e.data for e in read_log(tmp_path / "again.jsonl") if e.direction == "tx"]
    assert sent == [e.data for e in read_log(fixtures / "exchange.jsonl") if e.direction == "tx"]
