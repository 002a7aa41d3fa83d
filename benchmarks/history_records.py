"""Recording and reading back 10^4 calibrations in the history, on SQLite and on PostgreSQL.

Run::

    .venv/bin/python benchmarks/history_records.py [--count 10000] [--backend both]

Makes one real calibration (``simulate`` then ``identify --method lm``), then
COUNT copies that differ in their seed (so each is its own file with its own
SHA-256), and times ``History.record_calibration`` on each (one transaction
each, as ``identify --history`` records: the file read and checked, then
written) and ``History.calibrations(robot)`` reading them all back. The
PostgreSQL server is started from the ``pgserver`` package (test extra) in a
temporary folder. Prints the time per record, records a second, and the
read-back time.
"""

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

from calibrator.cli import main
from calibrator.history import open_history


def _make(folder: Path, count: int) -> list[Path]:
    for args in (
        ["simulate", "-o", str(folder / "s.parquet")],
        ["identify", str(folder / "s.parquet"), "-o", str(folder / "cal.json"), "--method", "lm"],
    ):
        try:
            main(args)
        except SystemExit as exc:
            if exc.code:
                raise
    doc = json.loads((folder / "cal.json").read_text())
    files = []
    for i in range(count):
        doc["seed"] = i
        path = folder / "many" / f"c{i:05d}.json"
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(doc))
        files.append(path)
    return files


def _run(target: str, session: Path, files: list[Path]) -> tuple[float, float, int]:
    with open_history(target) as h:
        h.record_session(session)
        started = time.perf_counter()
        for path in files:
            h.record_calibration(path)
        record_s = time.perf_counter() - started
        started = time.perf_counter()
        rows = h.calibrations(h.robots()[0]["name"])
        read_s = time.perf_counter() - started
    assert len(rows) == len(files)
    return record_s, read_s, len(rows)


def main_() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=10_000)
    parser.add_argument("--backend", choices=("sqlite", "postgresql", "both"), default="both")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="history-bench-"))
    server = None
    try:
        files = _make(folder, args.count)
        targets = []
        if args.backend in ("sqlite", "both"):
            targets.append(("sqlite", str(folder / "h.sqlite")))
        if args.backend in ("postgresql", "both"):
            import pgserver

            server = pgserver.get_server(tempfile.mkdtemp(prefix="history-bench-pg-"))
            targets.append(("postgresql", server.get_uri()))
        for name, target in targets:
            record_s, read_s, n = _run(target, folder / "s.parquet", files)
            print(
                f"{name:10s} {n} calibrations: recorded in {record_s:.1f} s "
                f"({record_s / n * 1e3:.2f} ms each, {n / record_s:.0f} a second); "
                f"read back in {read_s:.2f} s"
            )
    finally:
        if server is not None:
            data = server.pgdata
            server.cleanup()
            shutil.rmtree(data, ignore_errors=True)
        shutil.rmtree(folder, ignore_errors=True)


if __name__ == "__main__":
    main_()
