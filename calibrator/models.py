"""Named robot models: the entry point to :mod:`calibrator.robots`.

:func:`get_model` returns the arm's :class:`~calibrator.robots.RobotDescription`
(nominal MDH table, joint limits, motion ceilings, masses, capsule body,
named configurations, joint convention); :data:`RobotModel` is the same type
under its older name. Each arm's numbers and their sources live in its module
of :mod:`calibrator.robots`.

Motion ceilings
---------------
Every model carries a fixed ceiling on the speed (1.0 rad/s) and acceleration
(2.0 rad/s^2, or the lowest published acceleration limit if lower) of the
moves a calibration run commands. They sit well below the data sheets (UR's
slowest joints turn at 2.09 rad/s; URScript's default ``movej`` acceleration
is 1.4 rad/s^2 and ur-rtde accepts up to 40), because a calibration run gains
nothing from fast moves and a tracker cell is crowded. Options such as
``--speed``, ``--accel`` and ``--max-speed`` can only lower them.
"""

from __future__ import annotations

from calibrator import robots
from calibrator.robots import RobotDescription

#: The type :func:`get_model` returns (the older name of a robot description).
RobotModel = RobotDescription


def __getattr__(name: str) -> tuple[str, ...]:
    # MODEL_NAMES is computed when read: the set of arms is the package's modules.
    if name == "MODEL_NAMES":
        return robots.names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def get_model(name: str) -> RobotDescription:
    """Return the description of the arm called ``name`` (case-insensitive).

    Raises
    ------
    CalibrationError
        If no model has that name.
    """
    return robots.get(name)
