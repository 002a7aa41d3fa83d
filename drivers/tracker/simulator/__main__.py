"""Command line: ``python -m drivers.tracker.simulator (--pty | --tcp PORT) [options]``.

Prints one line per endpoint on stdout, in this order, then serves until
SIGTERM/SIGINT, until its parent process exits (unless ``--outlive-parent``),
or until a pty hang-up leaves no endpoint:

- ``--pty``: the slave device path (line 1), e.g. ``/dev/pts/7``;
- ``--tcp PORT``: the port number (0 picks a free one).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time
from pathlib import Path

from drivers.tracker.simulator.engine import TrackerSimulator
from drivers.tracker.simulator.faults import parse_script
from drivers.tracker.simulator.noise import NoiseModel
from drivers.tracker.simulator.replay import ReplaySimulator
from drivers.tracker.simulator.server import SimulatorServer


def _triple(text: str) -> list[float]:
    values = [float(v) for v in text.split(",")]
    if len(values) not in (3, 6):
        raise argparse.ArgumentTypeError("expected x,y,z or x,y,z,rx,ry,rz")
    return values


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m drivers.tracker.simulator",
        description="Simulated laser tracker over a pty and/or 127.0.0.1 TCP.",
    )
    p.add_argument("--pty", action="store_true", help="serve on a new pty; print its slave path")
    p.add_argument("--tcp", type=int, metavar="PORT", help="serve on 127.0.0.1:PORT (0 = free)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--no-noise", action="store_true", help="exact readings")
    p.add_argument("--probe-6dof", action="store_true", help="readings carry orientation (P6)")
    p.add_argument(
        "--target",
        type=_triple,
        metavar="X,Y,Z[,RX,RY,RZ]",
        help="initial true target, mm (and rad); default none",
    )
    p.add_argument("--initialised", action="store_true", help="start already initialised")
    p.add_argument("--init-time", type=float, default=0.2, metavar="S", help="INIT duration, s")
    p.add_argument("--serial", default="SIM-0001", help="serial number reported by ID?")
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


def _exit_with_parent(parent: int) -> None:
    """SIGTERM ourselves once the parent is gone, so crashed test runs leave no simulators."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os.kill(os.getpid(), signal.SIGTERM)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if not args.pty and args.tcp is None:
        build_parser().error("give --pty and/or --tcp PORT")
    if args.replay:
        engine = ReplaySimulator(args.replay)
    else:
        faults = parse_script(args.faults.read_text()) if args.faults else None
        engine = TrackerSimulator(
            seed=args.seed,
            noise=NoiseModel(enabled=not args.no_noise),
            probe_6dof=args.probe_6dof,
            faults=faults,
            init_time_s=args.init_time,
            initialised=args.initialised,
            serial=args.serial,
        )
        if args.target:
            engine.set_target(args.target[:3], args.target[3:] or None)
    server = SimulatorServer(engine)
    if args.pty:
        print(server.open_pty(), flush=True)
    if args.tcp is not None:
        print(server.open_tcp(args.tcp), flush=True)
    # SIGTERM ends the loop like Ctrl-C so the endpoints are closed cleanly.
    signal.signal(signal.SIGTERM, _interrupt)
    if not args.outlive_parent:
        threading.Thread(target=_exit_with_parent, args=(os.getppid(),), daemon=True).start()
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
