"""Orientation notations of robot programs: those of :mod:`calibrator.model.rotations`.

The one rotation module is :mod:`calibrator.model.rotations`; the language
modules import these names from here until they import it themselves.
"""

from calibrator.model.rotations import (
    matrix_to_quaternion,
    matrix_to_zyx,
    quaternion_to_matrix,
    zyx_to_matrix,
)

__all__ = ["matrix_to_quaternion", "matrix_to_zyx", "quaternion_to_matrix", "zyx_to_matrix"]
