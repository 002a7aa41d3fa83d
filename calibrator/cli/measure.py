"""``calibrator measure``: drive the robot through a plan and record a session with the tracker."""

from __future__ import annotations

import sys
from dataclasses import replace
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
        "plan as its own program: the tracker detects each stop; docs/external-robots.md).",
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
    retry_pause: float = typer.Option(
        0.2,
        callback=checks.finite(minimum=0.0, maximum=60.0),
        help="Pause before re-measuring a pose after a lost reading, s; doubled each "
        "further retry (up to 8 times).",
    ),
    ask_relock: bool = typer.Option(
        True,
        help="On a terminal, ask the operator to re-lock a lost beam (Enter) before a retry.",
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
        None,
        hidden=True,
        help="Control URL of a tracker simulator (either kind) the simulated robot steers.",
    ),
):
    """Measure a session: move, settle, average readings, journal each pose, write Parquet."""
    import contextlib
    import time

    marks = [("start", time.perf_counter())]

    from calibrator import outputs, progress
    from calibrator import plan as plans
    from calibrator.acquire.run import RunOptions

    output = Path(output)
    inputs = [p for p in (plan_path, sim_faults, sim_replay) if p is not None]
    outputs.check(output, inputs=inputs)
    for given in (sim_faults, sim_replay):
        if given is not None and not Path(given).is_file():
            _fail(f"file not found: {given}")
    arm = _check_motion_caps(model, speed, accel, max_speed)
    options = RunOptions(
        plan_rad=plans.read_csv(plan_path) if plan_path is not None else None,
        poses=poses,
        seed=seed,
        readings=readings,
        retries=retries,
        speed_rad_s=speed,
        accel_rad_s2=accel,
        retry_pause_s=retry_pause,
        tool_mm=_triple(tool, "--tool"),
        tracker_at_mm=_triple(tracker_at, "--tracker-at"),
        resume=resume,
    )
    external = _external_options(
        stop_band, settle_window, match_tolerance, stop_timeout, readings, options.tool_mm, quiet
    )
    with contextlib.ExitStack() as stack:
        run = stack.enter_context(
            _open_run(robot, tracker, arm, options, output, stack, sim_noise=sim_noise,
                      sim_faults=sim_faults, sim_replay=sim_replay, sim_record=sim_record,
                      sim_control=sim_control, max_speed=max_speed, external=external)
        )  # fmt: skip
        run.check_files()
        run.connect(tracker)
        marks.append(("connect (simulator start, links)", time.perf_counter()))
        run.make_plan(on_note=lambda text: typer.echo(f"note: {text}", err=True))
        marks.append(("plan (make and check)", time.perf_counter()))
        if settle is None:  # a real arm rings after a move; the simulated one does not
            run.options = options = replace(options, settle_s=0.5 if run.moves_hardware else 0.0)
        else:
            run.options = options = replace(options, settle_s=settle)
        run.open_journal(confirm=None if yes else _confirm)
        # A line per pose when piped: a measure run is slow enough to log each one.
        reporter = progress.Reporter.for_cli(quiet)
        reporter.interval_s = 0.0
        relock = _ask_relock if ask_relock and sys.stdin.isatty() else None
        with (
            _StopOnSigint() as interrupt,
            reporter.task("measure", len(run.plan), "poses") as task,
        ):
            run.measure(
                should_stop=lambda: interrupt.requested,
                on_pose=lambda p: task.update(p.done, **_pose_fields(p)),
                on_beam_lost=relock,
            )
        marks.append(("measure loop", time.perf_counter()))
        summary = run.finish()
        marks.append(("write session", time.perf_counter()))
    marks.append(("close (devices, simulator)", time.perf_counter()))
    if timings:
        for (_, t0), (what, t1) in zip(marks, marks[1:], strict=False):
            typer.echo(f"timing: {what}: {t1 - t0:.3f} s", err=True)
    for line in summary.notes:
        typer.echo(line)
    _report(summary, options)


def _external_options(
    band_mm: float,
    window_s: float,
    tolerance_mm: float,
    timeout_s: float,
    readings: int,
    tool_mm: tuple[float, float, float],
    quiet: bool,
):
    """``--robot external``: stop detection and association (used by that kind only)."""
    from drivers.robot.external.setup import ExternalOptions
    from drivers.robot.external.stops import StopOptions

    stops = StopOptions(band_mm, window_s, tolerance_mm, timeout_s)
    log = None if quiet else (lambda line: typer.echo(line, err=True))
    return ExternalOptions(stops, readings, tool_mm, log)


def _open_run(robot_url, tracker_url, arm, options, output, stack, *, sim_noise, sim_faults,
              sim_replay, sim_record, sim_control, max_speed, external=None):  # fmt: skip
    """The devices named by URL (the drivers' registries) and the run over them."""
    from calibrator.acquire.run import MeasureRun
    from calibrator.errors import CalibrationError
    from calibrator.simulate import SimWorld
    from drivers.robot import RobotOptions, open_robot
    from drivers.tracker import OpenOptions, open_tracker

    world = None
    if "sim" in (robot_url, tracker_url):
        world = SimWorld.make(arm.name, options.seed)
    try:
        tracker = open_tracker(
            tracker_url,
            OpenOptions(
                record=sim_record, world=world if tracker_url == "sim" else None,
                sim_noise=sim_noise, sim_faults=sim_faults, sim_replay=sim_replay,
            ),
        )  # fmt: skip
    except ValueError as exc:
        raise CalibrationError(f"--tracker: {exc}") from None
    # The tracker is handed to the robot too: an external robot finds its poses by
    # watching it (the run connects and closes it, once).
    robot_options = RobotOptions(
        arm, world, max_speed_rad_s=max_speed, tracker=tracker, external=external
    )
    try:
        robot = open_robot(robot_url, robot_options)
    except ValueError as exc:
        raise CalibrationError(f"--robot: {exc}") from None
    steer = None
    if sim_control is not None:
        steer = _sim_control(sim_control, robot, stack)
    return MeasureRun(robot, tracker, arm, options, output, world=world, steer=steer)


def _sim_control(url, robot, stack):
    """``--sim-control URL``: the simulated robot steers a simulator started by hand."""
    from calibrator.acquire.ports import REPORTS_TRUE_POSE
    from drivers.tracker.simulator.launch import SimulatorControl

    if REPORTS_TRUE_POSE not in robot.capabilities:
        _fail("--sim-control needs --robot sim (the simulated arm says where its probe is)")
    try:
        control = SimulatorControl(url)
    except (OSError, ValueError) as exc:
        _fail(f"--sim-control {url}: {exc}")
    stack.callback(control.close)
    return control.set_target


def _report(summary, options) -> None:
    """The run's last lines: what was written, what failed and why, what to do next."""
    resume_hint = f"rerun the same command with --resume to continue ({summary.journal})"
    causes = f": {summary.causes_text()}" if summary.causes else ""
    failed = f"{len(summary.failed)} pose(s) failed{causes}"
    if summary.written is None:
        what = "; ".join(x for x in (summary.stopped, failed if summary.failed else "") if x)
        typer.echo(
            f"calibrator: error: no pose measured, no session written: {what}; {resume_hint}",
            err=True,
        )
        raise typer.Exit(1)
    if summary.stopped:
        advice = ""
        if summary.stopped.startswith("robot halted"):
            advice = (
                "clear the stop on the pendant (after an e-stop: release it, power on "
                "and release the brakes), then "
            )
        kept = f"{len(summary.measured)} of {summary.total} poses kept"
        typer.echo(
            f"stopped: {summary.stopped}; {kept}"
            + (f"; {failed}" if summary.failed else "")
            + "; "
            + advice
            + resume_hint,
            err=True,
        )
        raise typer.Exit(1)
    if summary.failed:
        typer.echo(
            f"{failed} (after {options.retries} retries: poses {summary.failed[:10]}); "
            f"wrote {summary.written} with {len(summary.measured)} poses; "
            + resume_hint
            + " to retry them"
        )
        return
    n = len(summary.measured)
    typer.echo(f"wrote {summary.written}: {n} poses x {options.readings} readings")


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
    return arm


def _pose_fields(progress) -> dict:
    """Fields of the progress line after a pose: its plan row and spread (um) or FAILED."""
    record = progress.record
    if record["status"] != "measured":
        return {"pose": progress.pose, "spread_um": "FAILED"}
    import numpy as np

    return {"pose": progress.pose, "spread_um": float(np.linalg.norm(record["std_mm"]) * 1e3)}


def _ask_relock(pose: int, attempt: int) -> None:
    """On a terminal: let the operator re-lock the beam before the next attempt."""
    typer.prompt(
        f"beam lost at pose {pose}: re-lock it on the reflector, then press Enter "
        f"(attempt {attempt})",
        default="",
        show_default=False,
        err=True,
    )


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
