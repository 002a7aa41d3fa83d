"""Shared pytest options and fixtures.

Hardware tests skip unless the address of real hardware is given on the
command line (the pymeasure convention): ``--robot-host`` for a Universal
Robots controller, ``--tracker-url`` for a laser tracker (any pyserial URL).

The suite runs on two pytest-xdist workers (``-n 2 --dist loadgroup`` in
pyproject.toml; ``-n 0`` runs it in one process). Tests that share one
fixed resource run on one worker, one after another: those of the fake UR
controller (its fixed ports) and those of the PostgreSQL server a session
starts (one server, not one per worker).
"""

import pytest

#: Fixtures whose tests run on one worker, with the group they join.
_ONE_WORKER = {"fake_manager": "fake-ur", "pg_server": "postgresql"}
#: Names in a test module that mean it starts the fake UR controller itself.
_FAKE_UR_NAMES = {"FakeUrProcess", "FakeController"}


def pytest_collection_modifyitems(config, items):
    for item in items:
        groups = {_ONE_WORKER[f] for f in item.fixturenames if f in _ONE_WORKER}
        module = getattr(item, "module", None)
        if module is not None and _FAKE_UR_NAMES & set(vars(module)):
            groups.add("fake-ur")
        if groups:
            # A test needing both would need one group of both; none does.
            assert len(groups) == 1, (item.nodeid, groups)
            item.add_marker(pytest.mark.xdist_group(groups.pop()))


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
