"""Run the fake controller: ``python -m drivers.robot.ur.simulator [--time-scale X]``."""

from __future__ import annotations

import argparse
import os
import sys
import time

from drivers.robot.ur.simulator.controller import UNLOCK_DELAY_S, FakeController
from drivers.robot.ur.simulator.servers import (
    DASHBOARD_PORT,
    HOST,
    RTDE_PORT,
    SCRIPT_PORT,
    FakeUr,
    PortsInUse,
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m drivers.robot.ur.simulator",
        description="Loopback fake UR controller (default 127.0.0.1 ports 30004, 29999, 30003).",
    )
    parser.add_argument(
        "--host",
        default=HOST,
        help="loopback address to listen on, 127.x.y.z (default 127.0.0.1); each address has "
        "its own ports, so a fake on 127.0.0.2 never meets another run's fake",
    )
    for name, default in (("rtde", RTDE_PORT), ("dashboard", DASHBOARD_PORT),
                          ("script", SCRIPT_PORT)):  # fmt: skip
        parser.add_argument(f"--{name}-port", type=int, default=default, help=f"default {default}")
    parser.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        help="simulated seconds of motion per wall-clock second (default 1)",
    )
    parser.add_argument(
        "--model", default="ur5e", help="named model of calibrator.robots (default ur5e)"
    )
    parser.add_argument(
        "--unlock-delay",
        type=float,
        default=UNLOCK_DELAY_S,
        help="refuse 'unlock protective stop' this long after a stop, s (default 5, as UR)",
    )
    parser.add_argument(
        "--parent-pid",
        type=int,
        default=None,
        help="exit when this process is gone (a crashed test run leaves no fake)",
    )
    args = parser.parse_args(argv)

    from calibrator.errors import CalibrationError

    try:
        controller = FakeController(
            args.time_scale, model=args.model, unlock_delay_s=args.unlock_delay
        )
    except CalibrationError as exc:
        parser.error(str(exc))
    if not args.host.startswith("127."):
        parser.error(f"--host {args.host}: the fake listens on loopback addresses only (127.x)")
    ports = (args.rtde_port, args.dashboard_port, args.script_port)
    server = FakeUr(controller, args.host, ports)
    try:
        server.start()
    except PortsInUse as exc:
        print(f"fake_ur: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # e.g. an address this machine does not have
        reason = exc.strerror or exc
        print(f"fake_ur: error: cannot listen on {args.host}: {reason}", file=sys.stderr)
        return 2
    print(f"fake UR controller ready on {args.host}:{'/'.join(map(str, ports))}", flush=True)
    try:
        while not server.stopped.wait(0.2):
            if args.parent_pid is not None and not _alive(args.parent_pid):
                server.drop()
    except KeyboardInterrupt:
        server.drop()
    time.sleep(0.1)  # let the drop close sockets before the interpreter goes
    return 0


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


if __name__ == "__main__":
    sys.exit(main())
