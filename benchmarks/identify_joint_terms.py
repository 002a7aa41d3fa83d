"""The joint-term stage of ``identify``: wall time and what it buys.

Run::

    .venv/bin/python benchmarks/identify_joint_terms.py [--repeats 5] [--poses 30,60,120]

A simulated UR10e (MDH errors 0.3 mm / 3 mrad, 6-DoF data, 0.02 mm and
20 urad noise) with wrist gear-ratio errors (1, 2, -1.5 per mille on joints
4-6). For each session size: median wall time of
:func:`calibrator.identify.joint_fit.fit` with ``scale,harmonic`` (free-set decision,
cross-validation of both groups, final fit and uncertainty), and the mean
held-out position error of the geometry alone and with the kept terms.
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "joint"))

import joint_kit  # noqa: E402

from calibrator.identify import joint_fit  # noqa: E402
from calibrator.identify.problem import Problem  # noqa: E402
from calibrator.model import joint_terms, measurement

WRIST = joint_terms.JointTerms(
    np.array([0, 0, 0, 1e-3, 2e-3, -1.5e-3]), np.zeros(6), np.zeros(6), np.zeros(6)
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--poses", default="30,60,120")
    args = parser.parse_args()
    print(f"{'poses':>6s} {'median s':>9s} {'kept':>16s} {'held-out geo':>13s} {'with terms':>11s}")
    for n in (int(v) for v in args.poses.split(",")):
        parts, _ = joint_kit.sessions(WRIST, poses=n, seed=1)
        sess, tau, payload = joint_kit.merged(parts)
        geo = joint_kit.geometric_fit(sess, 0.2)
        o = sess.observations
        obs = measurement.Observations(o.q, o.points, o.rotations, tau)
        fit_obs, val_obs = obs.subset(geo.fit_index), obs.subset(geo.validation_index)
        times, found = [], None
        for _ in range(args.repeats):
            start = time.perf_counter()
            found = joint_fit.fit(
                Problem.of(geo.space, fit_obs, geo.k),
                geo.x,
                val_obs,
                ("scale", "harmonic"),
                0.02,
                payload[geo.fit_index],
            )
            times.append(time.perf_counter() - start)
        before = geo.stats["validation"]["after"]["position_mm"]["mean"]
        after = found.stats["validation"]["after"]["position_mm"]["mean"]
        kept = ",".join(found.kept) or "-"
        print(f"{n:6d} {statistics.median(times):9.2f} {kept:>16s} {before:13.4f} {after:11.4f}")


if __name__ == "__main__":
    main()
