"""IPSO inside ``calibrator identify`` against pyswarms, in the same run (check A4).

Run (pyswarms is a benchmark-only dependency)::

    .venv/bin/pip install -e '.[bench]'
    .venv/bin/python benchmarks/identify_swarm_vs_pyswarms.py [--repeats 5]

The IPSO paper's case (ER10L-C10, Table 2 errors, 32 poses, base frame,
orientation, no noise). IPSO's time is that of the swarm as a user runs it:
the difference between ``identify --method pso --generations 2000`` and
``--generations 1`` (a new process each, alternating, median CPU time of
each), so start-up, loading and writing cancel out. The reference is
pyswarms' ``GlobalBestPSO``, 20 particles x 2000 iterations, on the same
objective (7) written plainly with the public kinematics (``unpack`` then
``kinematics.forward`` for the whole swarm, 4x4 products), timed in this
process. CPU time, which other load on a shared machine inflates far less
than wall time; wall medians are printed beside it.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core, as the swarm uses

import numpy as np  # noqa: E402
from identify_scaling import run  # noqa: E402,I001 - the sibling benchmark script

from calibrator import session as session_io  # noqa: E402
from calibrator.identify import pipeline, pso  # noqa: E402
from calibrator.model import kinematics, parameters  # noqa: E402

CLI = [sys.executable, "-m", "calibrator"]
pyswarms = None  # imported in main(), in a temporary folder
SIMULATE = ["--poses", "32", "--seed", "3", "--noise-mm", "0", "--errors", "ref003"]


def plain_objective(space, obs, k):
    """Objective (7) for a swarm, written the obvious way: (P, D) -> (P,)."""
    q, points, rotations = obs.q, obs.points, obs.rotations

    def cost(x):
        mdh, base2tracker, flange2tool = space.unpack(x)
        pose = kinematics.forward(mdh, q, flange2tool, base2tracker)  # (P, N, 4, 4)
        d = pose[..., :3, 3] - points
        trace = np.einsum("nij,pnij->pn", rotations, pose[..., :3, :3])
        return np.einsum("pnj,pnj->p", d, d) + k * (3.0 - trace).sum(axis=1)

    return cost


def pyswarms_seconds(cost, lower, upper, particles, generations, seed):
    np.random.seed(seed)  # noqa: NPY002 - pyswarms draws from numpy's global generator
    k = pso.constriction(2.05, 2.05)  # Clerc's constriction as inertia weights
    opt = pyswarms.single.GlobalBestPSO(
        n_particles=particles,
        dimensions=len(lower),
        options={"c1": k * 2.05, "c2": k * 2.05, "w": k},
        bounds=(lower, upper),
    )
    wall, cpu = time.perf_counter(), time.process_time()
    opt.optimize(cost, iters=generations, verbose=False)
    return time.perf_counter() - wall, time.process_time() - cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--generations", type=int, default=2000)
    args = ap.parse_args()
    g = args.generations
    with tempfile.TemporaryDirectory() as tmp:
        # pyswarms writes ./report.log from its import on: keep it out of the
        # project. Imported here, before any timing: its import is slow.
        os.chdir(tmp)
        global pyswarms
        import pyswarms
        import pyswarms.single

        session = Path(tmp) / "session.parquet"
        simulate = [*CLI, "simulate", "-o", session, *SIMULATE]
        subprocess.run(simulate, check=True, capture_output=True)
        loaded = session_io.load(session)
        obs = loaded.observations
        fit_idx, _ = pipeline.split(len(obs), 0.2, 0)  # identify's default split and seed
        fit = obs.subset(fit_idx)
        candidates, _ = parameters.structural_candidates(loaded.meta.nominal_mdh, "base", True)
        space = parameters.ParameterSpace(loaded.meta.nominal_mdh, free=candidates)
        lower, upper = space.bounds()
        cost = plain_objective(space, fit, pipeline.DEFAULT_K)

        def identify(generations):
            out = Path(tmp) / "cal.json"
            row = run(
                [*CLI, "identify", session, "-o", out, "--force", "--method", "pso"]
                + ["--generations", str(generations)]
            )
            out.unlink()
            return row

        full, short, ref = [], [], []
        for rep in range(args.repeats):  # alternating, so slow spells hit all three
            full.append(identify(g))
            short.append(identify(1))
            ref.append(pyswarms_seconds(cost, lower, upper, 20, g, rep))

    def med(rows, i):
        return statistics.median(r[i] for r in rows)

    ipso_wall, ipso_cpu = med(full, 0) - med(short, 0), med(full, 1) - med(short, 1)
    ref_wall, ref_cpu = med(ref, 0), med(ref, 1)
    print(
        f"IPSO paper case, {len(fit)} fitting poses, {space.size} parameters, 20 particles x {g};"
        f" medians of {args.repeats}"
    )
    print(
        f"identify --method pso: {med(full, 1):.2f} s CPU ({med(full, 0):.2f} s wall) at {g}"
        f" generations, {med(short, 1):.2f} s CPU ({med(short, 0):.2f} s wall) at 1"
    )
    print(
        f"IPSO in identify (difference): {ipso_cpu:.3f} s CPU, {ipso_wall:.3f} s wall"
        f" = {ipso_cpu / (g - 1) * 1e6:.0f} us CPU per generation"
    )
    print(
        f"pyswarms GlobalBestPSO, plain objective: {ref_cpu:.3f} s CPU, {ref_wall:.3f} s wall"
        f" = {ref_cpu / g * 1e6:.0f} us CPU per iteration"
    )
    print(
        f"A4 ratio pyswarms / IPSO: {ref_cpu / ipso_cpu:.2f} (CPU),"
        f" {ref_wall / ipso_wall:.2f} (wall)"
    )


if __name__ == "__main__":
    main()
