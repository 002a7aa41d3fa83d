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


#: Where the shared checked plan's tracker stands (robot base frame, mm).
CHECKED_PLAN_TRACKER_MM = (2500.0, 400.0, 300.0)


@pytest.fixture(scope="session")
def checked_plan():
    """A 10-pose UR10e plan every check of ``measure`` and ``program`` passes, with 4 vias.

    Made once per test session by the real planner (a few seconds), tracker at
    :data:`CHECKED_PLAN_TRACKER_MM`, reflector at (0, 0, 100) mm on the flange.
    """
    from calibrator import cell as cells
    from calibrator import plan as plans
    from calibrator.models import get_model

    cell = cells.Cell(tracker_at_mm=CHECKED_PLAN_TRACKER_MM)
    made = plans.make_checked(get_model("ur10e"), 10, cell, (0, 0, 100), seed=0).plan
    assert made.n_vias, "the shared plan is meant to have vias"
    return made
