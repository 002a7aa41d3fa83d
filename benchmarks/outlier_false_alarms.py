"""How often ``identify`` warns about outliers on clean simulated sessions.

Run::

    .venv/bin/python benchmarks/outlier_false_alarms.py [--seeds 20] [--poses 40]

For each seed: ``calibrator measure --poses N --seed S`` on the simulated
cell (its own plan, the tracker simulator's noise over its pty), then
``calibrator identify``; prints the seeds whose identify output says
"possible outliers". In-process, a few seconds per seed (the plan is most
of it); the test suite checks the same with ``calibrator.simulate``
(tests/identify/test_outlier_rate.py).
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from cli_kit import cli  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--poses", type=int, default=40)
    args = parser.parse_args()
    start = time.perf_counter()
    warned = []
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(args.seeds):
            session = f"s{seed}.parquet"
            run = cli(
                "measure", "--poses", args.poses, "--seed", seed, "-q", "-o", session, cwd=folder
            )
            if run.code != 0:
                raise SystemExit(f"measure --seed {seed}: {run.stderr.strip()}")
            fit = cli("identify", session, "-o", f"c{seed}.json", cwd=folder)
            if fit.code != 0:
                raise SystemExit(f"identify --seed {seed}: {fit.stderr.strip()}")
            if "possible outliers" in fit.stdout + fit.stderr:
                warned.append(seed)
    print(
        f"{len(warned)} of {args.seeds} seeds warned about outliers {warned} "
        f"({args.poses}-pose sessions; {time.perf_counter() - start:.0f} s)"
    )


if __name__ == "__main__":
    main()
