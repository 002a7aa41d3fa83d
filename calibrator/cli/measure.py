"""``calibrator measure``: drive the robot through a plan and record a session with the tracker."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli._app import app


def _fail(message: str) -> None:
    typer.echo(f"calibrator: error: {message}", err=True)
    raise typer.Exit(2)


def _triple(text: str | None, option: str):
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(abs(v) < float("inf") for v in values):
        _fail(f"{option} needs X,Y,Z in mm, got {text!r}")
    return values


@app.command()
def measure(
    robot: str = typer.Option(
        "sim",
        help="sim, ur://HOST (a real UR controller), or external (any brand running the "
        "plan as its own program: the tracker detects each stop).",
    ),
    tracker: str = typer.Option(
        "sim",
        help="sim, a device path, a pyserial URL (socket://, rfc2217://), "
        "or emscon://HOST[:PORT][?meteo=T,P,H] (a Leica tracker's emScon server).",
    ),
    plan_path: Path = typer.Option(None, "--plan", help="Plan CSV (calibrator plan)."),
    poses: int = typer.Option(
        30, callback=checks.at_least(1), help="Poses of the plan made when --plan is not given."
    ),
    readings: int = typer.Option(
        10, callback=checks.at_least(1), help="Readings averaged per pose."
    ),
    output: Path = typer.Option(
        Path("session.parquet"), "-o", "--output", help="Session file (Parquet) to write."
    ),
    resume: bool = typer.Option(False, help="Continue the run recorded in OUTPUT.journal."),
    yes: bool = typer.Option(False, "--yes", help="Move a real robot without asking."),
    model: str = typer.Option("ur10e", help="Named model of the arm."),
    settle: float = typer.Option(
        None,
        callback=checks.finite(minimum=0.0),
        help="Wait after each move, s [default: 0.5 for ur://, 0 for sim].",
    ),
    retries: int = typer.Option(
        3, callback=checks.at_least(0), help="Re-measurements of a pose after a lost reading."
    ),
    speed: float = typer.Option(
        0.5,
        callback=checks.finite(0.0, inclusive=False),
        help="Leading-joint speed, rad/s (at most the model's fixed ceiling, 1.0).",
    ),
    accel: float = typer.Option(
        1.0,
        callback=checks.finite(0.0, inclusive=False),
        help="Leading-joint acceleration, rad/s^2 (at most the model's fixed ceiling, 2.0).",
    ),
    max_speed: float = typer.Option(
        None,
        callback=checks.finite(0.0, inclusive=False),
        help="Lower the speed cap the plan is checked against, rad/s "
        "[default: the model's fixed ceiling; it cannot be raised].",
    ),
    tracker_at: str = typer.Option(
        None, help="Tracker position in the robot base frame X,Y,Z (mm), for --poses plans."
    ),
    tool: str = typer.Option(
        "0,0,100", help="Reflector position on the flange X,Y,Z, mm (first guess; identified)."
    ),
    seed: int = typer.Option(
        0, callback=checks.at_least(0), help="Seed of the plan and of the simulated cell."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="No progress display."),
    stop_band: float = typer.Option(
        0.05,
        callback=checks.finite(0.0, inclusive=False),
        help="--robot external: stationarity band of a stop, mm.",
    ),
    settle_window: float = typer.Option(
        0.5,
        callback=checks.finite(0.0, inclusive=False),
        help="--robot external: how long readings stay in the band to make a stop, s.",
    ),
    match_tolerance: float = typer.Option(
        15.0,
        callback=checks.finite(0.0, inclusive=False),
        help="--robot external: largest distance of a stop from its expected pose, mm.",
    ),
    stop_timeout: float = typer.Option(
        30.0,
        callback=checks.finite(0.0, inclusive=False),
        help="--robot external: no stop for this long ends the program's poses (missing), s.",
    ),
    sim_noise: bool = typer.Option(True, hidden=True),
    sim_faults: Path = typer.Option(None, hidden=True, help="Fault script for the simulator."),
    sim_record: Path = typer.Option(None, hidden=True, help="Record the raw tracker exchange."),
    sim_replay: Path = typer.Option(None, hidden=True, help="Simulator answers from a recording."),
    timings: bool = typer.Option(False, hidden=True, help="Print where the time went (stderr)."),
    sim_control: str = typer.Option(
        None, hidden=True, help="Control URL of a tracker simulator the simulated robot steers."
    ),
):
    """Measure a session: move, settle, average readings, journal each pose, write Parquet."""
    import contextlib
    import time

    marks = [("start", time.perf_counter())]

    from calibrator import outputs, progress, session
    from calibrator import plan as plans
    from calibrator.acquire import journal as journals
    from calibrator.acquire import loop, rows
    from calibrator.acquire.ports import PortError
    from calibrator.cli import _hardware

    output = Path(output)
    inputs = [p for p in (plan_path, sim_faults, sim_replay) if p is not None]
    outputs.check(output, inputs=inputs)
    jpath = journals.journal_path(output)
    for given in (sim_faults, sim_replay):
        if given is not None and not Path(given).is_file():
            _fail(f"file not found: {given}")
    if not resume and output.exists():
        _fail(f"{output} exists: choose another -o, remove it, or pass --resume")
    if not resume and jpath.exists():
        _fail(f"{jpath} exists (an unfinished run): pass --resume to continue it, or remove it")
    if resume and not jpath.exists():
        _fail(f"nothing to resume: {jpath} not found")
    _check_motion_caps(model, speed, accel, max_speed)
    options = _hardware.RigOptions(
        model=model,
        seed=seed,
        sim_noise=sim_noise,
        sim_faults=str(sim_faults) if sim_faults else None,
        sim_record=str(sim_record) if sim_record else None,
        sim_replay=str(sim_replay) if sim_replay else None,
        sim_control=sim_control,
        max_speed_rad_s=max_speed,
        # The acceleration cap stays the model's ceiling: --accel is checked
        # against it above and never becomes its own limit.
        max_accel_rad_s2=None,
        tracker_at_mm=_triple(tracker_at, "--tracker-at"),
        external=_external_options(
            stop_band, settle_window, match_tolerance, stop_timeout, readings, quiet
        ),
    )
    with contextlib.ExitStack() as stack:
        tool_mm = _triple(tool, "--tool")
        try:
            rig = _hardware.build(robot, tracker, options, stack)
        except PortError as exc:  # a tracker that cannot be reached at the start: one line
            _fail(str(exc))
        rig.flange2tool_guess[:3, 3] = tool_mm
        marks.append(("connect (simulator start, links)", time.perf_counter()))
        # ---- the plan, checked whole before anything moves
        if plan_path is not None:
            q_plan = plans.read_csv(plan_path)
        else:
            if rig.tracker_at_mm is None:
                typer.echo("note: no --tracker-at: the plan ignores the acceptance angle", err=True)
            cell = plans.CellConstraints(
                tracker_at_mm=rig.tracker_at_mm, flange2tool=rig.flange2tool_guess
            )
            q_plan = plans.make(rig.model.mdh, rig.model.joint_limits_rad, poses, cell, seed=seed)
        need = plans.min_poses(rig.model.mdh)
        q_plan = plans.validate(q_plan, rig.model.joint_limits_rad, need=need)
        if hasattr(rig.robot, "check_plan"):
            from drivers.robot.errors import LimitsViolation

            try:
                rig.robot.check_plan(q_plan, speed, accel)
            except LimitsViolation as exc:
                _fail(str(exc))
        marks.append(("plan (make and check)", time.perf_counter()))
        settle_s = settle if settle is not None else (0.5 if rig.real_robot else 0.0)
        meta = session.SessionMeta(
            frame="tracker",
            nominal_mdh=rig.model.mdh,
            model=rig.model.name,
            flange2tool=rig.flange2tool_guess,
            tool_known=False,
            extra={"measured": {"robot": rig.robot_id, "tracker": rig.tracker_id}},
        )
        header = {
            "plan_sha256": plans.digest(q_plan),
            "robot": rig.robot_id,
            "tracker": rig.tracker_id,
            "readings": readings,
            "poses": len(q_plan),
            "meta": meta.to_json(),
        }
        if resume:
            journal, done = journals.Journal.resume(jpath, header)
            done = done.records
        else:
            if rig.real_robot and not yes:
                _confirm(rig.robot_id, len(q_plan))
            journal, done = journals.Journal.create(jpath, header), {}
        stack.callback(journal.close)
        if resume and rig.real_robot and not yes:
            left = len(q_plan) - sum(r["status"] == "measured" for r in done.values())
            _confirm(rig.robot_id, left)
        # A line per pose when piped: a measure run is slow enough to log each one.
        reporter = progress.Reporter.for_cli(quiet)
        reporter.interval_s = 0.0
        with (
            _StopOnSigint() as interrupt,
            reporter.task("measure", len(q_plan), "poses") as task,
        ):
            outcome = loop.run(
                q_plan,
                rig.robot,
                rig.tracker,
                journal,
                loop.LoopOptions(readings, settle_s, retries, speed, accel),
                done=done,
                after_move=rig.after_move,
                should_stop=lambda: interrupt.requested,
                on_pose=lambda p: task.update(p.done, **_pose_fields(p)),
            )
        journal.close()
        for line in rig.summary() if rig.summary is not None else ():
            typer.echo(line)
        marks.append(("measure loop", time.perf_counter()))
        measured, failed = outcome.measured, outcome.failed
        if measured:
            session.write(output, rows.to_table(outcome.records.values()), meta)
        marks.append(("write session", time.perf_counter()))
        if timings:
            for (_, t0), (what, t1) in zip(marks, marks[1:], strict=False):
                typer.echo(f"timing: {what}: {t1 - t0:.3f} s", err=True)
        resume_hint = f"rerun the same command with --resume to continue ({jpath})"
        if outcome.stopped:
            advice = ""
            if outcome.stopped.startswith("robot halted"):
                advice = (
                    "clear the stop on the pendant (after an e-stop: release it, power on "
                    "and release the brakes), then "
                )
            typer.echo(
                f"stopped: {outcome.stopped}; {len(measured)} of {len(q_plan)} poses kept; "
                + advice
                + resume_hint,
                err=True,
            )
            raise typer.Exit(1)
        if failed:
            typer.echo(
                f"{len(failed)} pose(s) failed after {retries} retries ({failed[:10]}); "
                f"wrote {output} with {len(measured)} poses; " + resume_hint + " to retry them"
            )
            return
        jpath.unlink()
        typer.echo(f"wrote {output}: {len(measured)} poses x {readings} readings")


def _external_options(band_mm, window_s, tolerance_mm, timeout_s, readings, quiet):
    """Options of ``--robot external`` (stop detection and association)."""
    from drivers.robot.external.setup import ExternalOptions
    from drivers.robot.external.stops import StopOptions

    stops = StopOptions(band_mm, window_s, tolerance_mm, timeout_s)
    return ExternalOptions(stops, readings, None if quiet else lambda m: typer.echo(m, err=True))


def _check_motion_caps(model_name, speed, accel, max_speed):
    """Refuse motion options above the model's fixed ceilings (exit 2).

    The ceilings (:attr:`calibrator.models.RobotModel.move_speed_cap_rad_s` and
    ``move_accel_cap_rad_s2``) are fixed per model; options can lower them only.
    """
    from calibrator.errors import CalibrationError
    from calibrator.models import get_model

    try:
        arm = get_model(model_name)
    except CalibrationError as exc:
        _fail(str(exc))
    speed_cap, accel_cap = arm.move_speed_cap_rad_s, arm.move_accel_cap_rad_s2
    if max_speed is not None and max_speed > speed_cap:
        _fail(
            f"--max-speed {max_speed} rad/s above the {arm.name} ceiling {speed_cap} rad/s: "
            "it can lower the cap, never raise it"
        )
    cap = speed_cap if max_speed is None else max_speed
    if speed > cap:
        _fail(f"--speed {speed} rad/s outside (0, {cap}] (the {arm.name} ceiling or --max-speed)")
    if accel > accel_cap:
        _fail(
            f"--accel {accel} rad/s^2 outside (0, {accel_cap}] (the {arm.name} ceiling; "
            "an option cannot raise it)"
        )


def _pose_fields(progress) -> dict:
    """Fields of the progress line after a pose: its plan row and spread (um) or FAILED."""
    record = progress.record
    if record["status"] != "measured":
        return {"pose": progress.pose, "spread_um": "FAILED"}
    import numpy as np

    return {"pose": progress.pose, "spread_um": float(np.linalg.norm(record["std_mm"]) * 1e3)}


def _confirm(robot_id: str, n: int) -> None:
    if not sys.stdin.isatty():
        _fail(f"the robot {robot_id} would move through {n} poses: pass --yes to confirm")
    if not typer.confirm(f"Move the robot {robot_id} through {n} poses?", default=False):
        _fail("not confirmed; nothing moved")


class _StopOnSigint:
    """SIGINT asks the loop to stop after the current pose; a second one interrupts at once."""

    def __init__(self):
        self.requested = False

    def _handle(self, signum, frame):
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        typer.echo("\nstopping after the current pose (Ctrl-C again to abort now)", err=True)

    def __enter__(self):
        import signal

        self._previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(self, *exc):
        import signal

        signal.signal(signal.SIGINT, self._previous)
