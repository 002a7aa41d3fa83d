"""The losses side by side: an outlier pose, unmodelled compliance, Gaussian noise.

Run::

    .venv/bin/python benchmarks/identify_losses.py [--seeds 5]

Cases (ER10L-C10 with seed-sized random errors, tool point known at 100 mm
on the flange axis, base frame), each over several seeds of the arm, poses
and noise; 30 % of the poses held out (20 % for the outlier case):

* **outlier**: 30 poses, 6-DoF, 0.02 mm / 0.1 mrad noise, one fitting pose's
  point moved 2 mm (a reflector reseated in the wrong nest); compared with
  the same session without the outlier.
* **compliance**: 60 position-only poses, 0.01 mm noise; in the truth joints
  2 and 3 bend under gravity by 0.2 mrad times the cosine of their link's
  angle to the horizontal, which no MDH table expresses.
* **gaussian**: the same 60 poses without compliance, 0.02 mm noise.

Reports the held-out position error (mean and max) and the worst fitted
pose of each loss, as medians over the seeds. The session builders are the
tests' (``tests/identify/identify_kit.py``).
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "identify"))
import identify_kit as arms  # noqa: E402

from calibrator.identify import pipeline  # noqa: E402
from calibrator.model import frames  # noqa: E402

TOOL = frames.transform(translation=[0.0, 0.0, 100.0])


def outlier_case(seed, with_outlier):
    robot, true = arms.truth_arm("er10l-c10", seed=seed)
    q = arms.joints(robot, 30, seed=seed + 100)
    pose = arms.measure(true, q, TOOL)
    if with_outlier:
        fit_idx, _ = pipeline.split(30, 0.2, 0)
        pose[fit_idx[5], :3, 3] += 2.0 * np.array([0.6, 0.8, 0.0])
    return arms.loaded(
        robot, q, pose, noise_mm=0.02, noise_rad=1e-4, seed=seed, tool_guess=TOOL, tool_known=True
    )


def arm_case(seed, compliance_rad, noise_mm):
    robot, true = arms.truth_arm("er10l-c10", seed=seed)
    q = arms.joints(robot, 60, seed=seed + 100)
    pose = arms.measure(true, q, TOOL, compliance_rad=compliance_rad)
    return arms.loaded(
        robot,
        q,
        pose,
        noise_mm=noise_mm,
        orientation=False,
        seed=seed,
        tool_guess=TOOL,
        tool_known=True,
    )


def figures(result):
    val, fit = result.stats["validation"]["after"], result.stats["fit"]["after"]
    return val["position_mm"]["mean"], val["position_mm"]["max"], fit["position_mm"]["max"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    rows = {}

    def record(case, loss, result, seconds):
        rows.setdefault((case, loss), []).append((*figures(result), seconds))

    for seed in range(args.seeds):
        clean = outlier_case(seed, False)
        record("outlier", "lsq, no outlier", pipeline.identify(clean, pipeline.Options()), 0.0)
        bad = outlier_case(seed, True)
        for loss in ("lsq", "huber", "trimmed"):
            t = time.perf_counter()
            result = pipeline.identify(bad, pipeline.Options(loss=loss))
            record("outlier", loss, result, time.perf_counter() - t)
        for case, comp, noise in (("compliance", 2e-4, 0.01), ("gaussian", 0.0, 0.02)):
            data = arm_case(seed, comp, noise)
            for loss in ("lsq", "minimax"):
                t = time.perf_counter()
                result = pipeline.identify(
                    data, pipeline.Options(loss=loss, validation_fraction=0.3)
                )
                record(case, loss, result, time.perf_counter() - t)

    print(f"medians over {args.seeds} seeds; position errors in mm")
    print(
        f"{'case':12s}{'loss':18s}{'held-out mean':>14s}{'held-out max':>14s}"
        f"{'fitted max':>12s}{'time s':>8s}"
    )
    for (case, loss), values in rows.items():
        med = np.median(np.array(values), axis=0)
        print(f"{case:12s}{loss:18s}{med[0]:14.4f}{med[1]:14.4f}{med[2]:12.4f}{med[3]:8.2f}")


if __name__ == "__main__":
    main()
