"""A plan every check of ``measure`` and ``program`` passes, shared by the tests."""

#: Where the shared checked plan's tracker stands (robot base frame, mm).
CHECKED_PLAN_TRACKER_MM = (2500.0, 400.0, 300.0)


def checked_plan():
    """A 10-pose UR10e plan every check of ``measure`` and ``program`` passes, with 4 vias.

    Made by the real planner (a few seconds), tracker at
    :data:`CHECKED_PLAN_TRACKER_MM`, reflector at (0, 0, 100) mm on the flange;
    use the session fixture ``checked_plan`` (tests/conftest.py) to make it once.
    """
    from calibrator import cell as cells
    from calibrator import planning, robots

    cell = cells.Cell(tracker_at_mm=CHECKED_PLAN_TRACKER_MM)
    made = planning.make_checked(robots.get("ur10e"), 10, cell, (0, 0, 100), seed=0).plan
    assert made.n_vias, "the shared plan is meant to have vias"
    return made
