"""``calibrator tracker status|init --tracker URL``: look at a tracker, initialise it."""

from __future__ import annotations

import dataclasses
import sys

import typer

from calibrator.cli._app import app
from calibrator.cli._options import fail as _fail

tracker_app = typer.Typer(
    help="Set up a laser tracker: its status, and initialising it (moves the head).",
    no_args_is_help=True,
)
app.add_typer(tracker_app, name="tracker")

URL_HELP = (
    "A device path, a pyserial URL (socket://, rfc2217://) or emscon://HOST[:PORT] "
    "(as measure --tracker)."
)


def _connected(url: str):
    """The tracker at ``url``, connected (never initialised), and its state."""
    from calibrator.acquire.ports import PortError
    from calibrator.cli._run import is_sim
    from drivers.tracker import open_tracker

    if is_sim(url):
        _fail("--tracker sim is started by measure itself, initialised; give a tracker's URL")
    try:
        tracker = open_tracker(url)
    except ValueError as exc:
        _fail(f"--tracker: {exc}")
    try:
        return tracker, tracker.connect()
    except (PortError, OSError) as exc:
        tracker.close()
        _fail(f"tracker at {url}: {exc}")
    raise AssertionError("unreachable")


def _describe(state) -> str:
    """``key=value`` pairs of a tracker state (whatever fields its kind reports)."""
    if dataclasses.is_dataclass(state) and not isinstance(state, type):
        fields = dataclasses.asdict(state)
    else:
        fields = {"initialised": state.initialised}
    return " ".join(f"{k}={v}" for k, v in fields.items())


@tracker_app.command()
def status(tracker: str = typer.Option(..., help=URL_HELP)) -> None:
    """Connect (never initialise) and print who answered and its state."""
    device, state = _connected(tracker)
    try:
        typer.echo(f"{device.device_id}: {_describe(state)}")
    finally:
        device.close()


@tracker_app.command()
def init(
    tracker: str = typer.Option(..., help=URL_HELP),
    yes: bool = typer.Option(False, "--yes", help="Initialise without asking."),
) -> None:
    """Initialise the tracker: its head moves (homing), so it asks first unless --yes."""
    from calibrator.acquire.ports import INITIALISE, PortError

    device, state = _connected(tracker)
    try:
        if state.initialised:
            typer.echo(f"{device.device_id}: already initialised")
            return
        head = device
        if not INITIALISE.offered_by(head):
            _fail(f"the tracker at {tracker} cannot be initialised from here")
        if not yes:
            if not sys.stdin.isatty():
                _fail(f"initialising {device.device_id} moves its head: pass --yes to confirm")
            if not typer.confirm(
                f"Initialise {device.device_id}? Its head will move.", default=False
            ):
                _fail("not confirmed; nothing moved")
        try:
            head.initialise()
            state = device.status()
        except (PortError, OSError) as exc:
            _fail(f"initialising the tracker at {tracker} failed: {exc}")
        if not state.initialised:
            _fail(f"the tracker at {tracker} still reports not initialised: {_describe(state)}")
        typer.echo(f"{device.device_id}: initialised")
    finally:
        device.close()
