"""Swarm objective evaluations per second, against the machine's arithmetic limit.

Run::

    .venv/bin/python benchmarks/identify_swarm_speed.py [--repeats 7]

The objective of the IPSO paper's case (ER10L-C10, 26 fitting poses, 24 free
parameters, orientation) is evaluated for a swarm of 20 particles, as in
one IPSO generation. Its useful arithmetic is counted by hand (per particle
and pose: six links, each a 3x4 by 4x4 product, 96 multiply-adds, and a
complex rotation of two columns, 18 flops; then the tool point and the
error terms); the machine's throughput is a large float64 matrix product
on one core. The ratio shows how far a generation is from the physical
limit: at these sizes the time goes to numpy's per-call overhead, not to
arithmetic. Times are CPU time of this (single-threaded) process, which
equals wall time on an idle machine and is not inflated by other load;
the wall time is printed beside it.
"""

import argparse
import os
import statistics
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the swarm uses

import numpy as np  # noqa: E402

from calibrator.identify import pipeline, pso  # noqa: E402
from calibrator.identify.problem import Problem  # noqa: E402
from calibrator.model import parameters  # noqa: E402
from calibrator.session import Session  # noqa: E402
from calibrator.simulate import simulate  # noqa: E402


def flops_per_evaluation(particles, poses, orientation):
    links = 6 * (3 * 4 * 4 * 2 + 18)  # 3x4 @ 4x4 and the complex turn
    point = 3 * 4 * 2 + 3 * 2 + 3  # tool point, error, squares
    rot = 9 * 2 if orientation else 0  # trace against the measured rotation
    setup = 6 * 60  # link constants per particle (cos, sin, products)
    return particles * (poses * (links + point + rot) + setup)


def machine_gflops(n=1500, repeats=3):
    a = np.random.default_rng(0).standard_normal((n, n))
    best = min(_timed(lambda: a @ a) for _ in range(repeats))
    return 2 * n**3 / best / 1e9


def _timed(fn, wall=None):
    t, c = time.perf_counter(), time.process_time()
    fn()
    if wall is not None:
        wall.append(time.perf_counter() - t)
    return time.process_time() - c


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--evaluations", type=int, default=2000)
    args = ap.parse_args()
    table, meta, _ = simulate(poses=32, seed=3, noise_mm=0.0)
    obs = Session(table, meta).observations
    fit_idx, _ = pipeline.split(len(obs), 0.2, 3)
    fit = obs.subset(fit_idx)
    candidates, _ = parameters.structural_candidates(meta.nominal_mdh, "base", True, True)
    space = parameters.ParameterSpace(meta.nominal_mdh, free=candidates)
    swarm = np.random.default_rng(1).normal(0, 1e-3, (20, space.size))
    rows, wall = [], []
    for loss in ("lsq", "minimax"):
        f = Problem.of(space, fit, pipeline.DEFAULT_K).swarm_objective(loss)
        f(swarm)
        wall.clear()
        per = [
            _timed(lambda f=f: [f(swarm) for _ in range(args.evaluations)], wall) / args.evaluations
            for _ in range(args.repeats)
        ]
        rows.append((loss, statistics.median(per), statistics.median(wall) / args.evaluations))
    lower, upper = space.bounds()
    f = Problem.of(space, fit, pipeline.DEFAULT_K).swarm_objective()
    ipso_wall = []
    ipso = [
        _timed(
            lambda s=s: pso.ipso(f, lower, upper, particles=20, generations=2000, seed=s),
            ipso_wall,
        )
        for s in range(args.repeats)
    ]
    peak = machine_gflops()
    flops = flops_per_evaluation(20, len(fit), True)
    print(f"IPSO paper case: 20 particles x {len(fit)} poses, {space.size} parameters")
    for loss, t, w in rows:
        print(
            f"objective ({loss}): {t * 1e6:.0f} us CPU per swarm evaluation, {1 / t:.0f}"
            f" evaluations/s = {20 / t:.0f} particle evaluations/s (wall {w * 1e6:.0f} us)"
        )
    t = rows[0][1]
    print(
        f"useful arithmetic {flops / 1e3:.0f} kflop per evaluation -> {flops / t / 1e9:.2f} GFLOP/s"
        f" achieved; machine (float64 matmul, one core) {peak:.1f} GFLOP/s;"
        f" arithmetic limit {flops / peak / 1e9 * 1e6:.0f} us per evaluation"
    )
    # The update loop alone: the same swarm on a free objective (a preallocated
    # zero vector), so what is left is the loop's own numpy calls.
    zeros = np.zeros(20)
    loop = [
        _timed(lambda s=s: pso.ipso(lambda x: zeros, lower, upper, generations=2000, seed=s))
        for s in range(args.repeats)
    ]
    run = statistics.median(ipso)
    print(
        f"IPSO 20 x 2000: median {run:.2f} s CPU"
        f" (wall {statistics.median(ipso_wall):.2f} s) over {args.repeats} seeds"
        f" = {run / 2000 * 1e6:.0f} us per generation, of which the update loop"
        f" {statistics.median(loop) / 2000 * 1e6:.0f} us and the objective"
        f" {rows[0][1] * 1e6:.0f} us"
    )


if __name__ == "__main__":
    main()
