"""Shared pytest options and fixtures.

Hardware tests skip unless the address of real hardware is given on the
command line (the pymeasure convention): ``--robot-host`` for a Universal
Robots controller, ``--tracker-url`` for a laser tracker (any pyserial URL).
"""

import pytest


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
