"""Target compensation: what to command so that the calibrated arm reaches its targets.

- :mod:`~calibrator.compensate.core`: joint angles of the calibrated arm and
  corrected targets for a controller that keeps its nominal model
  (:func:`compensate`, :func:`correction_sizes`);
- :mod:`~calibrator.compensate.targets`: a targets CSV read, compensated and
  written block by block (:func:`run`, :func:`iter_targets`,
  :func:`read_targets`);
- :mod:`~calibrator.compensate.programs`: a robot program read, compensated
  and spliced block by block through its language's reader
  (:func:`~calibrator.compensate.programs.run`; the nominal solve is
  :mod:`~calibrator.compensate.solve`). Not imported here: a targets CSV
  needs no language.

The inverse kinematics itself is :mod:`calibrator.model.inverse`.
"""

from calibrator.compensate.core import (
    MAX_JOINT_CHANGE_DEG,
    Compensation,
    compensate,
    correction_sizes,
)
from calibrator.compensate.targets import (
    DEG_COLUMNS,
    JOINT_COLUMNS,
    POSE_COLUMNS,
    Report,
    iter_targets,
    read_targets,
    run,
)

__all__ = [
    "DEG_COLUMNS",
    "JOINT_COLUMNS",
    "MAX_JOINT_CHANGE_DEG",
    "POSE_COLUMNS",
    "Compensation",
    "Report",
    "compensate",
    "correction_sizes",
    "iter_targets",
    "read_targets",
    "run",
]
