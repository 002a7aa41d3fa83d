"""Fixtures of the measure tests."""

import shutil

import pytest
from cli_process_kit import run_cli

BASE = ("measure", "--poses", "12", "-o", "s.parquet")


@pytest.fixture(scope="session")
def reference_session(tmp_path_factory):
    """An uninterrupted noise-free 12-pose run: what every faulted run must equal."""
    cwd = tmp_path_factory.mktemp("reference")
    done = run_cli("measure", "--poses", "12", "--tracker", "sim://?noise=off", "-o", "ref.parquet",
                   cwd=cwd)  # fmt: skip
    assert done.returncode == 0, done.stderr
    return cwd / "ref.parquet"


@pytest.fixture(scope="session")
def _pose_3_failed(tmp_path_factory):
    cwd = tmp_path_factory.mktemp("pose_3_failed")
    (cwd / "faults.txt").write_text("MEAS@31 beam_break count=40\n")
    done = run_cli(*BASE, "--tracker", "sim://?noise=off&faults=faults.txt", "--retries", "2",
                   cwd=cwd)  # fmt: skip
    return cwd, done


@pytest.fixture
def pose_3_failed(_pose_3_failed, tmp_path):
    """``tmp_path`` after a noise-free 12-pose run whose pose 3 failed (its beam broken
    through both retries): ``s.parquet`` without pose 3, ``s.parquet.journal`` kept for
    ``--resume``, ``faults.txt``. Returns that run's completed process.

    The run is made once and copied into each test's folder (the journal names no path).
    """
    folder, done = _pose_3_failed
    shutil.copytree(folder, tmp_path, dirs_exist_ok=True)
    return done
