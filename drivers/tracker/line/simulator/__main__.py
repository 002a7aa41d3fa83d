"""Command line: ``python -m drivers.tracker.line.simulator (--pty | --tcp PORT) [options]``.

Prints one line per endpoint on stdout, in this order, then serves until
SIGTERM/SIGINT, until its parent process exits (unless ``--outlive-parent``),
or until a pty hang-up leaves no endpoint:

- ``--pty``: the slave device path (line 1), e.g. ``/dev/pts/7``;
- ``--tcp PORT``: the port number (0 picks a free one).

A bad option, fault script, replay log or port gives one line on stderr and
exit status 2, and nothing on stdout.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from pathlib import Path

from drivers.tracker.instrument import NoiseModel, options, parse_script
from drivers.tracker.line.simulator.engine import TrackerSimulator
from drivers.tracker.line.simulator.replay import ReplaySimulator
from drivers.tracker.line.simulator.server import SimulatorServer


def _serial(text: str) -> str:
    # It goes into every ID? reply: one field of printable ASCII.
    if not (0 < len(text) <= 40 and text.isascii() and text.isprintable()) or set(text) & set(",*"):
        raise argparse.ArgumentTypeError(
            f"serial must be 1..40 printable ASCII characters without ',' or '*', got {text!r}"
        )
    return text


def build_parser() -> argparse.ArgumentParser:
    p = options.OneLineParser(
        prog="python -m drivers.tracker.line.simulator",
        description="Simulated laser tracker over a pty and/or 127.0.0.1 TCP.",
    )
    p.add_argument("--pty", action="store_true", help="serve on a new pty; print its slave path")
    p.add_argument(
        "--tcp", type=options.port, metavar="PORT", help="serve on 127.0.0.1:PORT (0 = free)"
    )
    p.add_argument("--seed", type=options.seed, default=0, help="noise seed (default 0)")
    p.add_argument("--no-noise", action="store_true", help="exact readings")
    p.add_argument("--probe-6dof", action="store_true", help="readings carry orientation (P6)")
    p.add_argument(
        "--target",
        type=options.triple,
        metavar="X,Y,Z[,RX,RY,RZ]",
        help="initial true target, mm (and rad); default none",
    )
    p.add_argument("--initialised", action="store_true", help="start already initialised")
    p.add_argument(
        "--air",
        type=options.air,
        default=(20.0, 1013.25, 50.0),
        metavar="T,P,H",
        help="air the station's sensors measure (COND?): degC, hPa, %%RH",
    )
    options.add_on_time(
        p, "time since power-on at start, s (COND?; warmed up after 2 h; default 3 h)"
    )
    p.add_argument(
        "--init-time", type=options.seconds, default=0.2, metavar="S", help="INIT duration, s"
    )
    options.add_time_scale(
        p,
        "its clock runs X times faster than the wall clock (reading stamps, INIT, time "
        "on); with the external-robot simulator at the same scale, a watched run is X times "
        "faster (default 1: real time)",
    )
    p.add_argument(
        "--latency",
        type=options.latency,
        default=0.0,
        metavar="S",
        help="how late its stamps are: a moving target is read where it was S seconds "
        "before the stamp (0..1, default 0)",
    )
    p.add_argument(
        "--serial", type=_serial, default="SIM-0001", help="serial number reported by ID?"
    )
    p.add_argument(
        "--faults",
        type=Path,
        metavar="FILE",
        help="fault script; syntax in docs/tracker-protocol.md",
    )
    p.add_argument("--replay", type=Path, metavar="LOG", help="answer from a recorded log")
    p.add_argument(
        "--outlive-parent",
        action="store_true",
        help="keep serving after the parent process exits (default: exit with it)",
    )
    return p


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not args.pty and args.tcp is None:
        parser.error("give --pty and/or --tcp PORT")
    try:
        server = _build_server(args)
    except (OSError, ValueError) as exc:
        # OSError: unreadable file, port taken; ValueError: a bad script or log (UnicodeError too)
        parser.error(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    # SIGTERM ends the loop like Ctrl-C so the endpoints are closed cleanly.
    signal.signal(signal.SIGTERM, _interrupt)
    if not args.outlive_parent:
        threading.Thread(target=options.exit_with_parent, args=(os.getppid(),), daemon=True).start()
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    return 0


def _build_server(args) -> SimulatorServer:
    """Engine and endpoints from the options; endpoints printed only once all opened."""
    if args.replay:
        try:
            engine: TrackerSimulator | ReplaySimulator = ReplaySimulator(args.replay)
        except ValueError as exc:
            message = str(exc)
            if str(args.replay) not in message:  # json's own errors do not name the file
                message = f"{args.replay}: {message}"
            raise ValueError(message) from None
    else:
        faults = None
        if args.faults:
            try:
                faults = parse_script(args.faults.read_text())
            except ValueError as exc:
                raise ValueError(f"{args.faults}: {exc}") from None
        simulator = TrackerSimulator(
            seed=args.seed,
            noise=NoiseModel(enabled=not args.no_noise),
            probe_6dof=args.probe_6dof,
            faults=faults,
            init_time_s=args.init_time,
            initialised=args.initialised,
            serial=args.serial,
            air=args.air,
            on_s=args.on_time,
            clock=options.scaled_clock(args.time_scale),
            latency_s=args.latency,
            time_scale=args.time_scale,
        )
        if args.target:
            simulator.set_target(args.target[:3], args.target[3:] or None)
        engine = simulator
    server = SimulatorServer(engine)
    lines = []
    try:
        if args.pty:
            lines.append(server.open_pty())
        if args.tcp is not None:
            lines.append(str(server.open_tcp(args.tcp)))
    except OSError:
        server.stop()
        raise
    for line in lines:
        print(line, flush=True)
    return server


if __name__ == "__main__":
    sys.exit(main())
