"""Shared pytest options and fixtures.

Hardware tests skip unless the address of real hardware is given on the
command line (the pymeasure convention): ``--robot-host`` for a Universal
Robots controller, ``--tracker-url`` for a laser tracker (any pyserial URL).

The suite runs on two pytest-xdist workers (``-n 2`` in pyproject.toml;
``-n 0`` runs it in one process), a test module at a time on either. The
tests of the fake UR controller share its fixed ports, so they all run on
one worker, one after another (a machine-wide lock would make the other
worker wait for them anyway).
"""

import functools
from pathlib import Path

import pytest
from xdist.scheduler import LoadScopeScheduling

#: Words in a test module that mean it runs the fake UR controller.
_FAKE_UR_WORDS = ("fake_ur", "fake_manager", "ur_robot", "FakeUrProcess", "acquire_ports")


@functools.cache
def _scope_of_file(path: str, root: str) -> str:
    """A module's own path, or ``fake-ur`` for every module that runs the fake UR."""
    text = (Path(root) / path).read_text(encoding="utf-8")
    return "fake-ur" if any(word in text for word in _FAKE_UR_WORDS) else path


class _ByModuleFakeUrTogether(LoadScopeScheduling):
    """xdist's per-module scheduling, with every fake-UR module in one scope.

    (xdist's ``loadgroup`` does this with marks, but it renames node ids
    through an attribute pytest 9.2 no longer reads, so its groups are lost.)
    """

    def _split_scope(self, nodeid: str) -> str:
        return _scope_of_file(nodeid.split("::", 1)[0], str(self.config.rootpath))


def pytest_xdist_make_scheduler(config, log):
    return _ByModuleFakeUrTogether(config, log)


def pytest_addoption(parser):
    parser.addoption("--robot-host", default=None, help="IP of a real UR controller")
    parser.addoption("--tracker-url", default=None, help="pyserial URL of a real tracker")


@pytest.fixture
def robot_host(request):
    host = request.config.getoption("--robot-host")
    if not host:
        pytest.skip("needs --robot-host")
    return host


@pytest.fixture
def tracker_url(request):
    url = request.config.getoption("--tracker-url")
    if not url:
        pytest.skip("needs --tracker-url")
    return url


@pytest.fixture(scope="session")
def checked_plan():
    """:func:`plan_kit.checked_plan`, made once per test session."""
    from plan_kit import checked_plan as make

    return make()


@pytest.fixture(scope="session")
def simulated_calibration(tmp_path_factory):
    """``s.parquet`` (``calibrator simulate --poses 20``) and its ``c.json`` (``identify
    --method lm``), made once per test run: ``{name: bytes}``; tests copy what they use."""
    from cli_kit import cli

    folder = tmp_path_factory.mktemp("simulated_calibration")
    made = cli("simulate", "-o", "s.parquet", "--poses", "20", cwd=folder)
    assert made.code == 0, made.stderr
    done = cli("identify", "s.parquet", "-o", "c.json", "--method", "lm", "-q", cwd=folder)
    assert done.code == 0, done.stderr
    return {name: (folder / name).read_bytes() for name in ("s.parquet", "c.json")}
