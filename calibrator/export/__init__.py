"""Vendor calibration files, written and read: one package for every format.

Writing: a format is one function registered with :func:`exporter`: it takes a
Calibration and returns an :class:`Exported` (the file's text and notes on
what the format could not hold). The CLI's ``--format`` choices and the
file-extension lookup come from :data:`REGISTRY`. The table and the
decorator live in :mod:`calibrator.export.registry` (the format modules
import them from there); importing this package imports every format
module, which registers its functions.

Reading: each vendor format's module reads what it writes
(:func:`calibrator.export.ur.read`, :func:`calibrator.export.ros.read`;
:func:`calibrator.export.urdf.like` rewrites a given URDF), and
:mod:`calibrator.export.factory_calibration` turns a UR calibration file or a
ROS kinematics YAML into the nominal model an identification starts from.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from calibrator import outputs
from calibrator.export.registry import REGISTRY, Exported, Format, Writer, exporter, format_names

if TYPE_CHECKING:
    from calibrator.calibration import Calibration

__all__ = [
    "REGISTRY",
    "Exported",
    "Format",
    "Writer",
    "choose",
    "export",
    "export_like",
    "exporter",
    "format_names",
]


def choose(fmt: str | None = None, output: outputs.PathLike | None = None) -> str:
    """The format to write: ``fmt`` if given, else from the output's name (stdout: json).

    Raises
    ------
    CalibrationError
        Unknown format, no way to tell, or a format that does not match the
        output file's extension (``-o out.xml`` with ``--format json``).
    """
    return outputs.choose_format(REGISTRY, fmt, output, default="json")


def export(calibration: Calibration, fmt: str) -> Exported:
    """Write ``calibration`` in format ``fmt``; returns :class:`Exported`."""
    outputs.known_format(REGISTRY, fmt)
    return _with_losses(REGISTRY[fmt].write(calibration), calibration, fmt)


def export_like(
    calibration: Calibration,
    like: outputs.PathLike,
    base_link: str | None = None,
    tip_link: str | None = None,
) -> Exported:
    """The user's URDF ``like`` with its chain calibrated (:func:`calibrator.export.urdf.like`)."""
    from calibrator.export import urdf

    return _with_losses(urdf.like(calibration, like, base_link, tip_link), calibration, "urdf")


def _with_losses(result: Exported, calibration: Calibration, fmt: str) -> Exported:
    # No format holds the joint terms: say what is lost.
    from calibrator.model.joint_terms import loss_note

    lost = loss_note(calibration.joint_terms)
    if lost:
        result = Exported(result.text, [*result.notes, f"{fmt} {lost}"])
    return result


# Importing the format modules registers them (order = order of --format choices).
from calibrator.export import tables as _tables  # noqa: E402,F401  isort: skip
from calibrator.export import ur as _ur  # noqa: E402,F401  isort: skip
from calibrator.export import ros as _ros  # noqa: E402,F401  isort: skip
from calibrator.export import urdf as _urdf  # noqa: E402,F401  isort: skip
