"""``python -m drivers.robot.external_sim``: play a plan on a true arm, steering a tracker sim.

Example (with a tracker simulator listening on TCP port 5001)::

    python -m drivers.robot.external_sim --plan plan.csv \\
        --control socket://127.0.0.1:5001 --model ur10e --seed 3 --skip 7

``--program circle.src`` plays a path program of ``calibrator program --path``
instead (KRL, RAPID or URScript; :mod:`drivers.robot.external_sim.path_program`):
its linear and circular moves at their stated speeds, solved by the
controller's nominal model and run by the hidden true arm, handed to the
tracker simulator as a timed path (``SIM,PATH``) it follows on its own clock.

``--wait-start`` loads the program and waits for a line on stdin before
it starts it, as an operator presses start (a test starts it the moment the
run watches). ``--time-scale 4`` plays the program four times faster than real time (moves,
dwells, pauses and ringing alike), as the fake UR controller's option does;
start the tracker simulator with the same ``--time-scale`` so that its
readings' stamps, by which ``measure --robot external`` times the stops, run
as fast.

Exit codes: 0 when the program ran to its end, 2 on bad input (one line),
1 when the tracker simulator's control link failed.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import fields
from typing import Any

from drivers.robot.external_sim.player import Player, PlayerOptions


def _poses(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected pose numbers like 3,7, got {text!r}") from None


def _point(text: str) -> tuple[float, float, float]:
    from calibrator.inputs import grammar
    from calibrator.inputs.errors import StrictError

    parts = text.split(",")
    try:
        if len(parts) != 3:
            raise StrictError("three numbers")
        x, y, z = (grammar.parse_number(p, "coordinate") for p in parts)
    except StrictError:
        raise argparse.ArgumentTypeError(f"expected X,Y,Z in mm, got {text!r}") from None
    if max(abs(x), abs(y), abs(z)) > 2000.0:
        raise argparse.ArgumentTypeError(f"a reflector within 2000 mm of the flange, got {text!r}")
    return x, y, z


def _pause(text: str) -> tuple[int, float, float]:
    try:
        pose, fraction, seconds = text.split(":")
        value = int(pose), float(fraction), float(seconds)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected POSE:FRACTION:SECONDS, got {text!r}") from None
    if not (0.0 < value[1] < 1.0 and value[2] > 0):
        raise argparse.ArgumentTypeError(f"FRACTION in (0, 1) and SECONDS > 0, got {text!r}")
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m drivers.robot.external_sim", description=__doc__
    )
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--plan", help="plan CSV (q1_rad..q6_rad; via rows are moved through)")
    source.add_argument(
        "--program", help="path program of `calibrator program --path` (.src, .mod, .script)"
    )
    parser.add_argument("--control", required=True, help="tracker simulator control URL")
    parser.add_argument("--model", default="ur10e")
    parser.add_argument("--seed", type=int, default=0, help="seed of the hidden true arm")
    parser.add_argument(
        "--world", help="world file (YAML, docs/check.md): the hidden arm worn, crashed, moved"
    )
    # Named as PlayerOptions' fields, so _options takes them over by name.
    for flag, dest, default, what in (
        ("--speed", "speed_rad_s", 1.0, "leading-joint speed, rad/s"),
        ("--accel", "accel_rad_s2", 2.0, "leading-joint accel, rad/s^2"),
        ("--dwell", "dwell_s", 1.5, "dwell at each pose, s"),
        ("--tick", "tick_s", 0.02, "target update period, s of the wall clock"),
        ("--vibration", "vibration_mm", 0.0, "ringing after a stop, mm"),
        ("--start-delay", "start_delay_s", 0.0, "wait before moving, s"),
        ("--time-scale", "time_scale", 1.0, "simulated s per wall-clock s (default 1: real time)"),
    ):
        metavar = flag[2:].upper().replace("-", "_")  # as without a dest: --dwell DWELL
        parser.add_argument(
            flag, dest=dest, metavar=metavar, type=float, default=default, help=what
        )
    parser.add_argument("--skip", type=_poses, default=(), help="poses the program skips: 3,7")
    parser.add_argument(
        "--pause",
        dest="pauses",
        metavar="PAUSE",
        type=_pause,
        action="append",
        default=[],
        help="POSE:FRACTION:SECONDS: stop that long that far into the move to POSE",
    )
    parser.add_argument(
        "--tool",
        type=_point,
        default=None,
        help="true reflector X,Y,Z on the flange, mm [default: the hidden cell's, near 0,0,100]",
    )
    parser.add_argument("--truth", help="write the hidden truth (JSON) here, for tests")
    parser.add_argument(
        "--wait-start",
        action="store_true",
        help="load everything, print 'ready', then start at a line on stdin (as an operator "
        "presses start on a loaded program)",
    )
    args = parser.parse_args(argv)
    if args.program:
        if args.skip or args.pauses:
            # A path program's moves are the program's: nothing here skips or pauses them.
            print("external_sim: error: --skip and --pause are for --plan", file=sys.stderr)
            return 2
        return _play_program(args)
    from calibrator.errors import CalibrationError
    from calibrator.planning import read_plan

    try:
        from calibrator import robots

        plan = read_plan(args.plan, robots.get(args.model))
        options = _options(args)
        world = None
        if args.world:
            from calibrator.world import read_world

            world = read_world(args.world)
        player = Player.for_model(
            plan.q_rad, args.model, args.seed, options, plan.via_rad, world=world, tool_mm=args.tool
        )
    except (CalibrationError, ValueError) as exc:
        print(f"external_sim: error: {exc}", file=sys.stderr)
        return 2
    if args.truth:
        player.write_truth(args.truth)
    return _on_control(args, lambda control: player.play(control.set_target))


def _play_program(args: argparse.Namespace) -> int:
    """``--program``: play a path program on the hidden true arm (exit codes as :func:`main`)."""
    import time

    import numpy as np

    from calibrator.errors import CalibrationError
    from drivers.robot.external_sim import path_program

    try:
        from calibrator import robots

        arm = robots.get(args.model)
        program = path_program.read(args.program)
        world = None
        if args.world:
            from calibrator.world import read_world

            world = read_world(args.world)
        start = arm.convention.to_model(np.asarray(program.start_rad).reshape(1, 6))
        hidden = Player.for_model(
            start, args.model, args.seed, _options(args), world=world, tool_mm=args.tool
        )
        t, points = path_program.true_path(
            program, arm, hidden.true_mdh, hidden.flange2tool, hidden.base2tracker
        )
    except (CalibrationError, ValueError) as exc:
        print(f"external_sim: error: {exc}", file=sys.stderr)
        return 2
    if args.truth:
        hidden.write_truth(args.truth)

    def run(control: Any) -> None:
        control.run_path(t, points, delay_s=args.start_delay_s)
        # The tracker's clock runs the path; the controller's program ends with it.
        time.sleep((args.start_delay_s + float(t[-1])) / args.time_scale)

    # The arm stands at the path's start before the program is started.
    return _on_control(args, run, before=lambda control: control.set_target(points[0]))


def _on_control(
    args: argparse.Namespace,
    play: Callable[[Any], None],
    before: Callable[[Any], None] | None = None,
) -> int:
    """Open the tracker simulator's control port, wait for the start, ``play`` on it.

    Returns the exit code (as :func:`main`): 2 for a control URL that cannot be
    opened, 1 for a link that fails while playing, 130 for Ctrl-C.
    """
    from drivers.tracker.line.simulator.launch import SimulatorControl

    try:
        control = SimulatorControl(args.control)
    except (OSError, ValueError) as exc:
        print(f"external_sim: error: --control {args.control}: {exc}", file=sys.stderr)
        return 2
    try:
        if before is not None:
            before(control)
        if args.wait_start:
            print("ready", flush=True)
            sys.stdin.readline()
        play(control)
    except OSError as exc:
        print(f"external_sim: control link failed: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    finally:
        control.close()
    return 0


def _options(args: argparse.Namespace) -> PlayerOptions:
    """The player's options from the parsed command line (dests named as the fields)."""
    given = {f.name: getattr(args, f.name) for f in fields(PlayerOptions)}
    return PlayerOptions(**{**given, "pauses": tuple(given["pauses"])})


if __name__ == "__main__":
    sys.exit(main())
