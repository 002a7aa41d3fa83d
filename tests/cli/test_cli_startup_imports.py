"""A command imports what it uses and no more: start-up is most of a short run.

Each case runs a command in a fresh interpreter (imports are per process) and
lists which heavy modules it loaded. Structural, not timed: a module that
comes back shows here whatever the machine's load.
"""

import json
import os
import subprocess
import sys

import pytest

PROBE = """
import json, os, sys
from calibrator.cli import main
try:
    main(sys.argv[1:])
except SystemExit as exc:
    code = exc.code
blas = os.environ.get("OPENBLAS_NUM_THREADS")
print(json.dumps({"code": code, "modules": sorted(sys.modules), "blas": blas}))
"""


def probe(*argv, env=None):
    out = subprocess.run(
        [sys.executable, "-c", PROBE, *map(str, argv)],
        capture_output=True,
        text=True,
        check=True,
        env=env,
        timeout=120,
    )
    report = json.loads(out.stdout.strip().splitlines()[-1])
    assert report["code"] == 0, out.stderr
    return report


def loaded(*argv):
    return set(probe(*argv)["modules"])


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    path = tmp_path_factory.mktemp("startup") / "session.parquet"
    subprocess.run(
        [sys.executable, "-m", "calibrator", "simulate", "-o", path, "--poses", "12"],
        check=True,
        capture_output=True,
        timeout=120,
    )
    return path


def test_swarm_only_identify_never_imports_scipy_optimize(session, tmp_path):
    modules = loaded(
        "identify", session, "-o", tmp_path / "cal.json", "--method", "pso", "--generations", "5"
    )
    assert "calibrator.identify.pipeline" in modules  # it did identify
    assert "scipy.optimize" not in modules
    assert "pyarrow.compute" not in modules  # a session already in pose order is not re-sorted


def test_default_identify_fits_least_squares_without_importing_scipy_optimize(session, tmp_path):
    out = tmp_path / "cal.json"
    modules = loaded("identify", session, "-o", out, "--generations", "5")
    doc = json.loads(out.read_text())
    assert doc["method"] == "hybrid"
    assert doc["solver"]["least_squares"]["evaluations"] > 1  # it did fit least squares
    assert "scipy.optimize" not in modules
    # Nothing else of scipy's on this path either: its package import alone is 0.03 s.
    assert not {m for m in modules if m == "scipy" or m.startswith("scipy.")}


def test_a_command_registers_only_itself(session, tmp_path):
    modules = loaded(
        "identify", session, "-o", tmp_path / "cal.json", "--method", "pso", "--generations", "5"
    )
    assert "calibrator.cli.identify" in modules
    others = {"calibrator.cli.export", "calibrator.cli.plan", "calibrator.cli.analyze"}
    assert not others & modules
    assert "calibrator.export" not in modules


def test_help_still_lists_every_command_in_workflow_order():
    out = subprocess.run(
        [sys.executable, "-m", "calibrator", "--help"],
        capture_output=True,
        text=True,
        check=True,
        timeout=120,
    ).stdout
    listed = [line.split()[0] for line in out.split("Commands:")[1].splitlines() if line.strip()]
    assert listed == [
        "plan",
        "program",
        "measure",
        "identify",
        "export-params",
        "compensate",
        "verify",
        "check",
        "report",
        "simulate",
        "tracker",
        "analyze",
        "history",
    ]


@pytest.mark.parametrize(("given", "expected"), [(None, "1"), ("2", "2")])
def test_identify_runs_one_blas_thread_unless_told(session, tmp_path, given, expected):
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if given is not None:
        env["OPENBLAS_NUM_THREADS"] = given
    report = probe(
        "identify",
        session,
        "-o",
        tmp_path / "cal.json",
        "--method",
        "pso",
        "--generations",
        "5",
        env=env,
    )
    assert report["blas"] == expected
