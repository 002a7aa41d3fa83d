"""What a caller may ask of any robot kind when opening it (:class:`RobotOptions`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from calibrator.simulate import SimWorld


@dataclass(frozen=True)
class RobotOptions:
    """What a caller may ask of any robot kind when opening it.

    Attributes
    ----------
    model : calibrator.robots.RobotDescription
        The named arm (limits, data-sheet motion caps).
    world : calibrator.simulate.SimWorld, optional
        The simulated world (the ``sim`` kind needs it).
    max_speed_rad_s, max_accel_rad_s2 : float, optional
        Lower the model's fixed motion caps (never raise them).
    external : calibrator.acquire.external.arm.ExternalOptions, optional
        Stop detection and association of the ``external`` kind.
    """

    model: Any
    world: SimWorld | None = None
    max_speed_rad_s: float | None = None
    max_accel_rad_s2: float | None = None
    external: Any = None
