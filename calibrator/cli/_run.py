"""What the commands that drive a robot past a tracker share (``measure``, ``verify``).

Parsing of motion and position options, the devices opened by URL around a
:class:`~calibrator.acquire.run.MeasureRun`, the operator's confirmation and
the Ctrl-C handling::

    arm = check_motion_caps(model, speed, accel, max_speed)     # exit 2 above the caps
    run = stack.enter_context(open_run(robot, tracker, arm, options, output, stack))
    run.open_journal(confirm=None if yes else confirm)
    with StopOnSigint() as interrupt:
        run.measure(should_stop=lambda: interrupt.requested, on_pose=...)
"""

from __future__ import annotations

import sys
from contextlib import ExitStack
from pathlib import Path
from typing import Any, NoReturn, overload

import typer

from calibrator.cli import _checks as checks

# ---------------------------------------------------------------- options
# The options every command that moves the arm shares (measure, verify), made
# here once so their limits and budgets cannot drift apart.


def readings_option(per: str = "pose") -> Any:
    """``--readings``: readings averaged per pose, within the shared budget."""
    return typer.Option(10, callback=checks.count("readings"), help=f"Readings averaged per {per}.")


def settle_option() -> Any:
    """``--settle``: wait after each move, s, within the shared budget."""
    return typer.Option(
        None,
        callback=checks.seconds("settle"),
        help="Wait after each move, s [default: 0.5 for ur://, 0 for sim].",
    )


def retries_option() -> Any:
    """``--retries``: re-measurements of a pose after a lost reading."""
    return typer.Option(
        3,
        callback=checks.count("retries", 0),
        help="Re-measurements of a pose after a lost reading.",
    )


def speed_option() -> Any:
    """``--speed``: leading-joint speed, rad/s (never above the model's ceiling)."""
    return typer.Option(
        0.5,
        callback=checks.finite(0.0, inclusive=False),
        help="Leading-joint speed, rad/s (at most the model's fixed ceiling, 1.0).",
    )


def accel_option() -> Any:
    """``--accel``: leading-joint acceleration, rad/s^2 (never above the model's ceiling)."""
    return typer.Option(
        1.0,
        callback=checks.finite(0.0, inclusive=False),
        help="Leading-joint acceleration, rad/s^2 (at most the model's fixed ceiling, 2.0).",
    )


def max_speed_option() -> Any:
    """``--max-speed``: lowers the speed cap; it cannot raise the model's ceiling."""
    return typer.Option(
        None,
        callback=checks.finite(0.0, inclusive=False),
        help="Lower the speed cap the plan is checked against, rad/s "
        "[default: the model's fixed ceiling; it cannot be raised].",
    )


def fail(message: str) -> NoReturn:
    """One line naming what was wrong, exit code 2."""
    typer.echo(f"calibrator: error: {message}", err=True)
    raise typer.Exit(2)


@overload
def triple(text: str, option: str) -> tuple[float, float, float]: ...
@overload
def triple(text: None, option: str) -> None: ...
def triple(text: str | None, option: str) -> tuple[float, float, float] | None:
    """``X,Y,Z`` (mm) of ``option`` to three finite floats, or None when not given."""
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(abs(v) < float("inf") for v in values):
        fail(f"{option} needs X,Y,Z in mm, got {text!r}")
    return values  # type: ignore[return-value]


def check_motion_caps(model_name: str, speed: float, accel: float, max_speed: float | None) -> Any:
    """Refuse motion options above the model's fixed ceilings (exit 2); the named model.

    The ceilings (:attr:`calibrator.models.RobotModel.move_speed_cap_rad_s` and
    ``move_accel_cap_rad_s2``) are fixed per model; options can lower them only.
    """
    from calibrator.errors import CalibrationError
    from calibrator.models import get_model

    try:
        arm = get_model(model_name)
    except CalibrationError as exc:
        fail(str(exc))
    speed_cap, accel_cap = arm.move_speed_cap_rad_s, arm.move_accel_cap_rad_s2
    if max_speed is not None and max_speed > speed_cap:
        fail(
            f"--max-speed {max_speed} rad/s above the {arm.name} ceiling {speed_cap} rad/s: "
            "it can lower the cap, never raise it"
        )
    cap = speed_cap if max_speed is None else max_speed
    if speed > cap:
        fail(f"--speed {speed} rad/s outside (0, {cap}] (the {arm.name} ceiling or --max-speed)")
    if accel > accel_cap:
        fail(
            f"--accel {accel} rad/s^2 outside (0, {accel_cap}] (the {arm.name} ceiling; "
            "an option cannot raise it)"
        )
    return arm


def open_run(
    robot_url: str,
    tracker_url: str,
    arm: Any,
    options: Any,
    output: Path,
    stack: ExitStack,
    *,
    sim_noise: bool = True,
    sim_faults: Path | None = None,
    sim_replay: Path | None = None,
    sim_record: Path | None = None,
    sim_control: str | None = None,
    max_speed: float | None = None,
    sim_repeatability: bool = False,
    sim_probe_6dof: bool = False,
    external: Any = None,
) -> Any:
    """The devices named by URL (the drivers' registries) and the run over them.

    Parameters
    ----------
    arm : calibrator.models.RobotModel
    options : calibrator.acquire.run.RunOptions
    sim_repeatability : bool
        The simulated arm has a typical arm's joint positioning error and
        backlash (seeded from ``options.seed``); off, it lands exactly.
    sim_probe_6dof : bool
        The simulated tracker's probe reports its orientation too.
    external : drivers.robot.external.setup.ExternalOptions, optional
        Stop detection and association of ``--robot external``.

    Returns
    -------
    calibrator.acquire.run.MeasureRun
        Not connected yet; enter it (``with``) so its devices are closed.
    """
    from calibrator.acquire.run import MeasureRun
    from calibrator.errors import CalibrationError
    from calibrator.simulate import SimWorld
    from drivers.robot import RobotOptions, open_robot
    from drivers.tracker import OpenOptions, open_tracker

    world = None
    if "sim" in (robot_url, tracker_url):
        repeatability = None
        if sim_repeatability:
            from drivers.robot.simulated import JointRepeatability

            repeatability = JointRepeatability.typical()
        world = SimWorld.make(arm.name, options.seed, repeatability=repeatability)
    try:
        tracker = open_tracker(
            tracker_url,
            OpenOptions(
                record=sim_record, world=world if tracker_url == "sim" else None,
                sim_noise=sim_noise, sim_faults=sim_faults, sim_replay=sim_replay,
                sim_probe_6dof=sim_probe_6dof,
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


def _sim_control(url: str, robot: Any, stack: ExitStack) -> Any:
    """``--sim-control URL``: the simulated robot steers a simulator started by hand."""
    from calibrator.acquire.ports import REPORTS_TRUE_POSE
    from drivers.tracker.simulator.launch import SimulatorControl

    if REPORTS_TRUE_POSE not in robot.capabilities:
        fail("--sim-control needs --robot sim (the simulated arm says where its probe is)")
    try:
        control = SimulatorControl(url)
    except (OSError, ValueError) as exc:
        fail(f"--sim-control {url}: {exc}")
    stack.callback(control.close)
    return control.set_target


def pose_fields(progress: Any) -> dict:
    """Fields of the progress line after a pose: its plan row and spread (um) or FAILED."""
    record = progress.record
    if record["status"] != "measured":
        return {"pose": progress.pose, "spread_um": "FAILED"}
    import numpy as np

    return {"pose": progress.pose, "spread_um": float(np.linalg.norm(record["std_mm"]) * 1e3)}


def confirm(robot_id: str, n: int) -> None:
    """Ask the operator before a real robot moves through ``n`` poses (exit 2 unless yes)."""
    if not sys.stdin.isatty():
        fail(f"the robot {robot_id} would move through {n} poses: pass --yes to confirm")
    if not typer.confirm(f"Move the robot {robot_id} through {n} poses?", default=False):
        fail("not confirmed; nothing moved")


class StopOnSigint:
    """SIGINT asks the loop to stop after the current pose; a second one interrupts at once."""

    def __init__(self) -> None:
        self.requested = False

    def _handle(self, signum: int, frame: Any) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True
        typer.echo("\nstopping after the current pose (Ctrl-C again to abort now)", err=True)

    def __enter__(self) -> StopOnSigint:
        import signal

        self._previous = signal.signal(signal.SIGINT, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        import signal

        signal.signal(signal.SIGINT, self._previous)
