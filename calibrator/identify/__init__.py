"""``identify``: MDH parameters (and joint terms) from sessions, as a Python API.

::

    from calibrator import identify

    options = identify.Options(method="lm", seed=2)        # each option's default and rule
    done = identify.run(["session.parquet"], "calibration.json", options)
    again = identify.recall("calibration.json", "session.parquet", {"seed": 3})  # --like

:class:`Options` and :class:`JointTermOptions` are declared in
:mod:`calibrator.recorded_options` (beside the calibration documents that
record them); :func:`run` and :func:`recall` are those of
:mod:`calibrator.identify.calibrate` (whose :func:`~calibrator.identify.calibrate.calibrate`
builds the document without writing it). The names load on first use, so
importing one step of the method (``calibrator.identify.levmar``) does not
load the whole command.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from calibrator.identify.calibrate import Calibrated, Recalled, recall, run
    from calibrator.recorded_options import JointTermOptions, Options

__all__ = [
    "Calibrated",
    "JointTermOptions",
    "Options",
    "Recalled",
    "recall",
    "run",
]

_OPTIONS = ("JointTermOptions", "Options")


def __getattr__(name: str) -> Any:
    if name in _OPTIONS:
        from calibrator import recorded_options

        return getattr(recorded_options, name)
    if name in __all__:
        # By its full name: "from calibrator.identify import calibrate" would ask this again.
        import calibrator.identify.calibrate as module

        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
