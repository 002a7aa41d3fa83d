"""The simulator-only ``SIM,...`` commands, the same for both simulated front-ends.

The line simulator takes them on its own wire; the emScon simulator on its
control port. Either way they are line-protocol frames (so one
:class:`~drivers.tracker.line.simulator.launch.SimulatorControl` steers
both), values always mm and rad, and they are not counted by fault triggers.
See docs/tracker-protocol.md, "Simulator-only commands".
"""

from __future__ import annotations

from drivers.tracker.instrument.instrument import Instrument
from drivers.tracker.line.protocol import (
    Command,
    ErrorCode,
    error_body,
    ok_body,
    parse_number,
)


def sim_command(instrument: Instrument, cmd: Command) -> str:
    """The reply body to ``SIM,TARGET`` / ``NOTARGET`` / ``FAULT`` / ``PATH,...``.

    Parameters
    ----------
    instrument : Instrument
        The tracker the command steers.
    cmd : Command
        A parsed ``SIM`` frame (``cmd.args[0]`` names the command).

    Returns
    -------
    str
        ``OK`` (``PATH,GO``'s carries the start in us), or an ``ER`` body:
        ``UNKNOWN_COMMAND`` for a command it does not know, ``BAD_PARAMETER``
        naming what was wrong.
    """
    with instrument.lock:
        try:
            what, *args = cmd.args
            if what == "TARGET" and len(args) in (3, 6):
                values = [parse_number(a) for a in args]
                instrument.set_target(values[:3], values[3:] or None)
            elif what == "NOTARGET" and not args:
                instrument.clear_target()
            elif what == "PATH" and args:
                return _path(instrument, cmd.seq, args)
            elif what == "FAULT" and len(args) == 1:
                instrument.arm_fault(args[0])
            else:
                return error_body(cmd.seq, ErrorCode.UNKNOWN_COMMAND, "SIM," + what)
        except ValueError as exc:
            return error_body(cmd.seq, ErrorCode.BAD_PARAMETER, str(exc))
        return ok_body(cmd.seq)


def _path(instrument: Instrument, seq: int, args: list[str]) -> str:
    """``SIM,PATH,CLEAR`` / ``SIM,PATH,POINT,t,x,y,z[,rx,ry,rz]`` / ``SIM,PATH,GO[,delay]``.

    Waypoints (time from the path's start, s; mm and rad) are collected,
    then ``GO`` moves the target through them (:meth:`Instrument.start_path`);
    the ``OK`` carries the start on the tracker's clock in microseconds.
    """
    what, rest = args[0], args[1:]
    if what == "CLEAR" and not rest:
        instrument.clear_path()
        return ok_body(seq)
    if what == "POINT" and len(rest) in (4, 7):
        instrument.add_waypoint([parse_number(a) for a in rest])
        return ok_body(seq)
    if what == "GO" and len(rest) <= 1 and instrument.waypoints:
        start = instrument.start_path(parse_number(rest[0]) if rest else 0.0)
        return ok_body(seq, int(start * 1e6))
    return error_body(seq, ErrorCode.UNKNOWN_COMMAND, "SIM,PATH," + what)
