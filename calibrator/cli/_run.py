"""What the commands that drive a robot past a tracker share (``measure``, ``verify``, ``check``).

Their options (declared once here; the ones all take word for word arrive
parsed as one :class:`RunArgs`), the devices named by ``--robot`` and
``--tracker`` (:func:`devices`: the simulated cell's settings in its URLs),
the operator's confirmation and the Ctrl-C handling. The run itself is a
procedure (:mod:`calibrator.acquire.procedure`); the command parses, hands
it a :class:`calibrator.cli._console.Console` and prints::

    @app.command()
    @run_command
    def measure(*, robot: str = robot_option(external=True), run_args: RunArgs, ...):
        arm = run_args.arm()                                    # exit 2 above the caps
        options = RunOptions(..., **run_args.run_fields())
        devices = _run.devices(*device_urls(robot, tracker, world_file=world_file))
        console = Console(quiet=quiet, yes=run_args.yes)
        summary = calibrator.acquire.measure.run(arm, options, output, devices, console)
"""

from __future__ import annotations

import functools
import inspect
import sys
from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, get_type_hints, overload

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._options import fail

# ---------------------------------------------------------------- options
# The options every command that moves the arm shares (measure, verify), made
# here once so their limits and budgets cannot drift apart.

#: The trackers ``--tracker`` opens (``drivers.tracker.open_tracker``).
TRACKER_URLS = (
    "a device path, a pyserial URL (socket://, rfc2217://), "
    "or emscon://HOST[:PORT][?meteo=T,P,H] (a Leica tracker's emScon server)"
)


def robot_option(external: bool) -> Any:
    """``--robot``: sim, ur://HOST, and with ``external`` a robot the tracker watches."""
    if external:
        kinds = (
            "sim, ur://HOST (a real UR controller), or external (any brand running the "
            "plan as its own program: the tracker detects each stop; docs/external-robots.md)."
        )
    else:
        kinds = "sim, or ur://HOST (a real UR controller)."
    return typer.Option("sim", help=kinds)


def tracker_option() -> Any:
    """``--tracker``: sim or a tracker's URL."""
    return typer.Option("sim", help=f"sim, {TRACKER_URLS}.")


def resume_option() -> Any:
    """``--resume``: continue the run the journal beside the output recorded."""
    return typer.Option(False, help="Continue the run recorded in OUTPUT.journal.")


def yes_option() -> Any:
    """``--yes``: move a real robot without asking."""
    return opts.yes("Move a real robot without asking.")


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


def speed_option(
    default: float | None = 0.5, limit: str = "(at most the model's fixed ceiling, 1.0)"
) -> Any:
    """``--speed``: leading-joint speed, rad/s (never above the model's ceiling)."""
    return opts.positive(default, f"Leading-joint speed, rad/s {limit}.")


def accel_option(
    default: float | None = 1.0, limit: str = "(at most the model's fixed ceiling, 2.0)"
) -> Any:
    """``--accel``: leading-joint acceleration, rad/s^2 (never above the model's ceiling)."""
    return opts.positive(default, f"Leading-joint acceleration, rad/s^2 {limit}.")


def max_speed_option() -> Any:
    """``--max-speed``: lowers the speed cap; it cannot raise the model's ceiling."""
    return opts.positive(
        None,
        "Lower the speed cap the plan is checked against, rad/s "
        "[default: the model's fixed ceiling; it cannot be raised].",
    )


@dataclass(frozen=True)
class RunArgs:
    """The options measure and verify take word for word, parsed (see :func:`run_command`).

    Attributes
    ----------
    resume, yes, force : bool
        ``--resume``, ``--yes`` and ``--force`` (replace an existing output;
        an unfinished run's journal is still only resumed or removed).
    model : str or None
        ``--model``, a named arm; None when not given (the input files' arm,
        else :data:`calibrator.cli._model.DEFAULT`).
    settle : float or None
        ``--settle``, s; None: the default of the robot kind.
    retries : int
    speed, accel : float
        Leading-joint speed (rad/s) and acceleration (rad/s^2).
    max_speed : float or None
        ``--max-speed``, rad/s; None: the model's ceiling.
    """

    resume: bool
    yes: bool
    force: bool
    model: str | None
    settle: float | None
    retries: int
    speed: float
    accel: float
    max_speed: float | None

    def arm(self, *recorded: Any) -> Any:
        """The arm, the motion options checked against its ceilings (exit 2 above).

        Parameters
        ----------
        *recorded : calibrator.cli._model.From
            The arm each input file records: it is the arm, and a ``--model``
            naming another is refused (:func:`calibrator.cli._model.resolve`).
        """
        from calibrator.cli import _model

        name = _model.resolve(self.model, *recorded)
        return check_motion_caps(name, self.speed, self.accel, self.max_speed)

    def run_fields(self) -> dict[str, Any]:
        """The :class:`~calibrator.acquire.run.RunOptions` fields these options set."""
        return {
            "retries": self.retries,
            "speed_rad_s": self.speed,
            "accel_rad_s2": self.accel,
            "resume": self.resume,
            "force": self.force,
        }

    def settle_s(self, moves_hardware: bool) -> float:
        """``--settle``, else 0.5 s on hardware (a real arm rings after a move), 0 simulated."""
        if self.settle is not None:
            return self.settle
        return 0.5 if moves_hardware else 0.0


def _run_args_options() -> list[inspect.Parameter]:
    """The options of :class:`RunArgs` as parameters, in the order ``--help`` lists them."""
    declared = {
        "resume": resume_option(),
        "yes": yes_option(),
        "force": opts.force(),
        "model": opts.model(
            None,
            "Named model of the arm [default: the input file's (plan, calibration), else "
            "ur10e]; an input file's arm cannot be changed.",
        ),
        "settle": settle_option(),
        "retries": retries_option(),
        "speed": speed_option(),
        "accel": accel_option(),
        "max_speed": max_speed_option(),
    }
    types = get_type_hints(RunArgs)
    return [
        inspect.Parameter(
            name, inspect.Parameter.KEYWORD_ONLY, default=option, annotation=types[name]
        )
        for name, option in declared.items()
    ]


def run_command(command: Callable[..., None]) -> Callable[..., None]:
    """Give ``command`` the options of :class:`RunArgs`, declared once, where it has ``run_args``.

    The command declares a parameter ``run_args: RunArgs`` among its options;
    typer sees the shared options in its place (so ``--help`` lists them there)
    and the command receives them parsed into one :class:`RunArgs`. Use it
    below ``@app.command()``.
    """
    own = inspect.signature(command).parameters
    if "run_args" not in own:
        raise TypeError(f"{command.__name__} has no run_args parameter")
    hints = get_type_hints(command)
    params: list[inspect.Parameter] = []
    for p in own.values():
        if p.name == "run_args":
            params += _run_args_options()
        else:
            params.append(p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=hints[p.name]))
    shared = [f.name for f in fields(RunArgs)]

    @functools.wraps(command)
    def parsed(**given: Any) -> None:
        run_args = RunArgs(**{name: given.pop(name) for name in shared})
        command(run_args=run_args, **given)

    parsed.__signature__ = inspect.Signature(params, return_annotation=None)  # type: ignore[attr-defined]
    parsed.__annotations__ = {p.name: p.annotation for p in params}
    return parsed


@overload
def triple(text: str, option: str) -> tuple[float, float, float]: ...
@overload
def triple(text: None, option: str) -> None: ...
def triple(text: str | None, option: str) -> tuple[float, float, float] | None:
    """``X,Y,Z`` (mm) of ``option`` to three finite floats, or None when not given."""
    if text is None:
        return None
    x, y, z = opts.floats(text, 3, option, "X,Y,Z in mm")
    return x, y, z


def check_motion_caps(model_name: str, speed: float, accel: float, max_speed: float | None) -> Any:
    """Refuse motion options above the model's fixed ceilings (exit 2); the named model.

    The ceilings (:attr:`calibrator.robots.RobotDescription.move_speed_cap_rad_s` and
    ``move_accel_cap_rad_s2``) are fixed per model; options can lower them only.
    """
    from calibrator import robots
    from calibrator.errors import CalibrationError

    try:
        arm = robots.get(model_name)
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


def kind(url: str) -> str:
    """The device kind ``url`` names: its scheme (``ur`` for ``ur://HOST``) or its bare word."""
    from drivers.registry import scheme

    return scheme(url)


def is_sim(url: str) -> bool:
    """``url`` names the simulated device: ``sim``, or ``sim://?...`` with its settings."""
    from drivers.devices import is_sim as sim

    return sim(url)


def device_urls(
    robot_url: str, tracker_url: str, *, world_file: Any = None, repeatability: bool = False
) -> tuple[str, str]:
    """``--robot`` and ``--tracker`` with what the command and the world file say of the cell.

    The simulators are configured by their URLs (``sim://?noise=off&probe=6dof``,
    ``sim://?repeatability=typical``): a world file's ``noise: false`` and
    ``repeatability: true``, and ``repeatability`` (``verify``'s default), are
    written into them unless the URL says otherwise.

    Returns
    -------
    (str, str)
        The robot's and the tracker's URL; unchanged when nothing is to be said.
    """
    from drivers.devices import sim_settings

    noise = True
    if world_file is not None:
        noise = world_file.noise
        repeatability = repeatability or world_file.repeatability
    if is_sim(tracker_url) and not noise and "noise" not in sim_settings(tracker_url):
        tracker_url = _with_settings(tracker_url, {"noise": "off"})
    if is_sim(robot_url) and repeatability and "repeatability" not in sim_settings(robot_url):
        robot_url = _with_settings(robot_url, {"repeatability": "typical"})
    return robot_url, tracker_url


def sim_files(tracker_url: str) -> tuple[list[Path], Path | None]:
    """The files a simulated tracker's URL names: inputs (faults, replay) and its record.

    Raises
    ------
    typer.Exit
        An input file that does not exist (exit 2, before anything opens).
    """
    from drivers.devices import sim_settings

    given = sim_settings(tracker_url)
    inputs = [Path(given[name]) for name in ("faults", "replay") if given.get(name)]
    for path in inputs:
        if not path.is_file():
            fail(f"file not found: {path}")
    record = given.get("record")
    return inputs, Path(record) if record else None


def _with_settings(url: str, settings: dict[str, str]) -> str:
    """``sim`` or ``sim://?a=1`` with ``settings`` added to its query."""
    from urllib.parse import urlencode

    if not settings:
        return url
    if "://" not in url:
        url += "://"
    return url + ("&" if "?" in url else "?") + urlencode(settings)


def devices(
    robot_url: str,
    tracker_url: str,
    *,
    world_file: Any = None,
    max_speed: float | None = None,
    external: Any = None,
) -> Any:
    """``--robot`` and ``--tracker`` (simulator settings in their URLs) as the devices to open."""
    from drivers.devices import Devices

    return Devices(
        robot_url, tracker_url, world=world_file, max_speed_rad_s=max_speed, external=external
    )


#: ``--world``: a world file for the simulated cell (docs/check.md).
WORLD_HELP = (
    "World file (YAML, docs/check.md) of the simulated cell: the true arm's wear, "
    "joint-zero shifts, base, reflector and noise."
)


def read_world(path: Path | None, robot_url: str, tracker_url: str) -> Any:
    """``--world FILE`` parsed (exit 2 on a bad file), or None; only for a simulated cell."""
    if path is None:
        return None
    if not (is_sim(robot_url) or is_sim(tracker_url)):
        fail("--world is for the simulated cell (--robot sim or --tracker sim)")
    from calibrator.world import WorldError, read_world

    try:
        return read_world(path)
    except WorldError as exc:
        fail(str(exc))


def pose_fields(progress: Any) -> dict:
    """Fields of the progress line after a pose: its plan row and spread (um) or FAILED."""
    record = progress.record
    if record["status"] != "measured":
        return {"pose": progress.pose, "spread_um": "FAILED"}
    import numpy as np

    return {"pose": progress.pose, "spread_um": float(np.linalg.norm(record["std_mm"]) * 1e3)}


def confirm(robot_id: str, n: int, guessed: str | None = None) -> None:
    """Ask the operator before a real robot moves through ``n`` poses (exit 2 unless yes).

    ``guessed``: what of the arm's collision body is guessed
    (:func:`calibrator.planning.guessed_geometry`), said in the question.
    """
    poses = f"{n} poses" + (f" checked against guessed geometry ({guessed})" if guessed else "")
    if not sys.stdin.isatty():
        fail(f"the robot {robot_id} would move through {poses}: pass --yes to confirm")
    if not typer.confirm(f"Move the robot {robot_id} through {poses}?", default=False):
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
