"""Fixtures of the measure tests."""

import pytest
from cli_process import run_cli


@pytest.fixture(scope="session")
def reference_session(tmp_path_factory):
    """An uninterrupted noise-free 12-pose run: what every faulted run must equal."""
    cwd = tmp_path_factory.mktemp("reference")
    done = run_cli("measure", "--poses", "12", "--no-sim-noise", "-o", "ref.parquet", cwd=cwd)
    assert done.returncode == 0, done.stderr
    return cwd / "ref.parquet"
