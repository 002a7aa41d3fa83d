"""Joint values and frames as a controller states them, and as the model reads them.

A controller's joint angles can differ from the kinematic model's by a sign
and a zero offset per joint, and on some arms by a coupling of joints 2 and 3
(Fanuc's J2/J3). The arm's description states it
(:class:`calibrator.robots.JointConvention`); every joint value the filter
reads or writes passes through :func:`to_model` and :func:`to_controller`
with the convention of the calibration's arm (:func:`for_model`). Frames
too are the controller's: its base (world) frame and its flange (tool 0)
are placed on the model by :func:`controller_frames`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from calibrator.robots import JointConvention

#: The model's own angles (an arm whose controller states joints as its model does).
IDENTITY = JointConvention()


def for_model(name: str | None) -> JointConvention:
    """The controller convention of the arm ``name`` (a model or description file).

    Raises
    ------
    calibrator.errors.CalibrationError
        No arm of that name (the calibration names an arm this program cannot find).
    """
    if not name:
        return IDENTITY
    from calibrator import robots

    return robots.get(name).convention


def controller_frames(name: str | None) -> tuple[np.ndarray, np.ndarray]:
    """The controller's base frame in MDH frame 0 and its flange on the MDH flange, (4, 4) each.

    Of the arm ``name`` (:attr:`calibrator.robots.RobotDescription.model_base2controller_base`
    and ``model_flange2controller_flange``, mm); identities for no name.
    """
    if not name:
        return np.eye(4), np.eye(4)
    from calibrator import robots

    arm = robots.get(name)
    return arm.model_base2controller_base, arm.model_flange2controller_flange


def to_model(q_controller: ArrayLike, convention: JointConvention = IDENTITY) -> np.ndarray:
    """Controller joint angles (rad), shape (N, 6), to the model's (rad)."""
    return convention.to_model(q_controller)


def to_controller(q_model: ArrayLike, convention: JointConvention = IDENTITY) -> np.ndarray:
    """The model's joint angles (rad), shape (N, 6), to the controller's (rad)."""
    return convention.to_controller(q_model)
