"""Compensation of 10,000 targets: wall time and IK failures.

Run::

    .venv/bin/python benchmarks/compensate.py [--repeats 7] [--targets 10000]

A UR10e with hidden MDH errors (0.5 mm and, per case, 2 mrad or 10 mrad on
the angles: Hayati's parameter set), a tool 100 mm off the flange, and
nominal joint targets drawn in a work cell in front of the robot (shoulder
+-1 rad, elbow bent 0.6..2 rad, wrist 5 away from 0). Times
:func:`calibrator.compensate.compensate` (IK on the calibrated arm from the
nominal solution, then the corrected targets), median of the repeats, and
counts the targets it could not reach (not converged, or outside the joint
limits).
"""

import argparse
import statistics
import time

import numpy as np

from calibrator import compensate, robots, simulate
from calibrator.calibration import Calibration
from calibrator.model import frames


def work_cell(n, rng):
    return np.column_stack(
        [
            rng.uniform(-1.0, 1.0, n),
            rng.uniform(-2.2, -1.0, n),
            rng.uniform(0.6, 2.0, n),
            rng.uniform(-2.5, -0.5, n),
            rng.uniform(0.5, 2.5, n),
            rng.uniform(-3.0, 3.0, n),
        ]
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--targets", type=int, default=10_000)
    args = ap.parse_args()
    robot = robots.get("ur10e")
    for rad in (0.002, 0.01):
        rng = np.random.default_rng(0)
        cal = Calibration(
            nominal_mdh=robot.mdh,
            mdh=robot.mdh + simulate.random_errors(robot.mdh, rng, mm=0.5, rad=rad),
            flange2tool=frames.transform(None, [0.0, 0.0, 100.0]),
            model="ur10e",
        )
        q = work_cell(args.targets, rng)
        times = []
        for _ in range(args.repeats):
            t = time.perf_counter()
            out = compensate.compensate(cal, q_nominal=q, limits=robot.joint_limits_rad)
            times.append(time.perf_counter() - t)
        sol = out.solution
        print(
            f"errors 0.5 mm / {rad * 1e3:g} mrad: {args.targets} targets in "
            f"{statistics.median(times):.3f} s (median of {args.repeats}, "
            f"min {min(times):.3f}), IK failures {int((~sol.ok).sum())} "
            f"(not converged {int((~sol.converged).sum())}, outside limits "
            f"{int((sol.converged & ~sol.within_limits).sum())}), "
            f"median iterations {int(np.median(sol.iterations))}, max {int(sol.iterations.max())}"
        )


if __name__ == "__main__":
    main()
