"""Run the fake controller: ``python -m drivers.robot.fake_ur [--time-scale X]``."""

import argparse
import os
import sys
import time

from drivers.robot.fake_ur.controller import UNLOCK_DELAY_S, FakeController
from drivers.robot.fake_ur.servers import FakeUr


def main(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m drivers.robot.fake_ur",
        description="Loopback fake UR controller on 127.0.0.1 ports 30004, 29999, 30003.",
    )
    parser.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        help="simulated seconds of motion per wall-clock second (default 1)",
    )
    parser.add_argument(
        "--model", default="ur5e", help="named model of calibrator.models (default ur5e)"
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
    server = FakeUr(controller)
    server.start()
    print("fake UR controller ready on 127.0.0.1:30004/29999/30003", flush=True)
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
