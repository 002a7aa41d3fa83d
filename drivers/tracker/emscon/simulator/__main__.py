"""Command line: ``python -m drivers.tracker.emscon.simulator [options]``.

Prints two lines on stdout, the emScon port then the control port (both on
127.0.0.1), then serves until SIGTERM/SIGINT or until its parent exits
(unless ``--outlive-parent``).
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from pathlib import Path

from drivers.tracker.emscon.simulator.engine import EmsconSimulator
from drivers.tracker.emscon.simulator.server import EmsconServer
from drivers.tracker.instrument import NoiseModel, options, parse_script


def build_parser() -> argparse.ArgumentParser:
    p = options.OneLineParser(
        prog="python -m drivers.tracker.emscon.simulator",
        description="Simulated Leica emScon server on 127.0.0.1 (emScon port + control port).",
    )
    p.add_argument("--port", type=int, default=0, help="emScon port (0 = free; real: 700)")
    p.add_argument("--control-port", type=int, default=0, help="SIM,... control port (0 = free)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (default 0)")
    p.add_argument("--no-noise", action="store_true", help="exact readings")
    p.add_argument("--target", type=options.triple, metavar="X,Y,Z", help="initial true target, mm")
    p.add_argument("--initialised", action="store_true", help="start already initialised")
    p.add_argument("--init-time", type=float, default=0.2, metavar="S", help="Initialize, s")
    p.add_argument("--serial", type=int, default=390001, help="tracker serial number")
    p.add_argument("--faults", type=Path, metavar="FILE", help="fault script (shared syntax)")
    p.add_argument(
        "--ack-start",
        action="store_true",
        help="acknowledge StartMeasurement before its result (default: result only)",
    )
    p.add_argument("--probe", action="store_true", help="a 6-DoF probe (ProbeStationaryResult)")
    p.add_argument(
        "--latency",
        type=options.latency,
        default=0.0,
        metavar="S",
        help="how late continuous results' stamps are for a moving target, s (0..1)",
    )
    p.add_argument(
        "--air",
        type=options.air,
        metavar="T,P,H",
        help="a weather station on the tracker measures this air (degC, hPa, %%RH) and the "
        "server corrects with it (default: no station; the client's parameters)",
    )
    options.add_on_time(
        p, "time since power-on at start, s (its laser reports heating up until 2 h; default 3 h)"
    )
    options.add_time_scale(
        p, "its clock runs X times faster than the wall clock (default 1: real time)"
    )
    p.add_argument("--outlive-parent", action="store_true", help="keep serving after parent exits")
    return p


def _interrupt(signum, frame):
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        faults = parse_script(args.faults.read_text()) if args.faults else None
    except (OSError, ValueError) as exc:
        print(f"error: --faults: {exc}", file=sys.stderr)
        return 2
    engine = EmsconSimulator(
        seed=args.seed,
        noise=NoiseModel(enabled=not args.no_noise),
        faults=faults,
        init_time_s=args.init_time,
        initialised=args.initialised,
        serial=args.serial,
        ack_start=args.ack_start,
        probe=args.probe,
        latency_s=args.latency,
        air=args.air,
        on_s=args.on_time,
        clock=options.scaled_clock(args.time_scale),
        time_scale=args.time_scale,
    )
    if args.target:
        engine.set_target(args.target[:3])
    server = EmsconServer(engine)
    try:
        port, control = server.open(args.port, args.control_port)
    except OSError as exc:
        print(f"error: cannot listen: {exc}", file=sys.stderr)
        return 2
    print(port, flush=True)
    print(control, flush=True)
    signal.signal(signal.SIGTERM, _interrupt)
    if not args.outlive_parent:
        threading.Thread(target=options.exit_with_parent, args=(os.getppid(),), daemon=True).start()
    server.start()
    try:
        server.wait()
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    return 0


if __name__ == "__main__":
    sys.exit(main())
