"""A test that hangs is a failing test.

Every test runs under a deadline (pytest-timeout, installed by the test
extra, its limit in ``[tool.pytest.ini_options]``): a test that starts a
process, a server or a loop and never returns is stopped and reported as
failed, naming itself, instead of holding the suite until CI's own limit.
The per-test deadlines inside the tests (pipe reads, stream stalls,
subprocess ``timeout=``) stay: they fail sooner and say what was awaited.
"""

import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

HANGS = textwrap.dedent(
    """
    import threading


    def test_waits_for_ever():
        threading.Event().wait()
    """
)


def _pytest_options() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["tool"]["pytest"][
        "ini_options"
    ]


def test_every_test_has_a_deadline_in_the_project_configuration():
    options = _pytest_options()
    limit = float(options["timeout"])
    # Long enough for the slowest test on a loaded two-core machine, short enough
    # that a hung test fails well inside CI's 15 minutes.
    assert 60 <= limit <= 600
    test_extra = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"][
        "optional-dependencies"
    ]["test"]
    assert any(req.startswith("pytest-timeout") for req in test_extra)


def test_a_test_waiting_for_ever_is_failed_by_the_deadline(tmp_path):
    (tmp_path / "test_hangs.py").write_text(HANGS, encoding="utf-8")
    # The project's configuration file, its limit shortened for the test; one process.
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-c",
            str(ROOT / "pyproject.toml"),
            "--rootdir",
            str(tmp_path),
            "-p",
            "no:cacheprovider",
            "-o",
            "addopts=-n 0",
            "-o",
            "timeout=2",
            str(tmp_path / "test_hangs.py"),
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1, done.stdout[-3000:] + done.stderr[-2000:]
    assert "1 failed" in done.stdout
    assert "Timeout" in done.stdout
    assert "test_waits_for_ever" in done.stdout
