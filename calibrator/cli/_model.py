"""The arm a command works on: the one its input file names, ``--model`` only where none does.

A plan, a calibration and a session record the arm they were made for. A
command reading one takes that arm, so ``program plan.csv`` of a KUKA's plan
writes a KUKA program without being told twice; ``--model`` names the arm
only for files that record none (old plans, a calibration of a session's
own table), and a ``--model`` that names another arm is refused, naming
both, in one line (exit 2)::

    from calibrator.cli import _model

    name = _model.resolve(model, _model.From(plan.origin and plan.origin.model, plan_path))
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from os import PathLike
from typing import Any

from calibrator.cli._options import fail
from calibrator.inputs.messages import a_or_an

#: The arm of a command whose inputs name none and that is given no ``--model``.
DEFAULT = "ur10e"


@dataclass(frozen=True)
class From:
    """The arm one input file records.

    Attributes
    ----------
    model : str or None
        The recorded name (a shipped arm, or a description file's path as
        recorded, ``arm.urdf#base:tip``); None when the file records none.
    source : str or path-like
        The file, for messages.
    """

    model: str | None
    source: str | PathLike[str]


def same(a: str, b: str) -> bool:
    """Whether two model names name one arm (case and surrounding spaces aside)."""
    return a.strip().lower() == b.strip().lower()


def resolve(given: str | None, *recorded: From, default: str | None = DEFAULT) -> Any:
    """The name of the arm: the input files', else ``--model``, else ``default``.

    Parameters
    ----------
    given : str or None
        ``--model`` (with ``--base-link``/``--tip-link`` folded in), None when not given.
    *recorded : From
        What each input file records (files without a record are skipped).
    default : str or None
        The arm when neither names one.

    Returns
    -------
    str or None
        The recorded name as the file spells it, ``given``, or ``default``.

    Raises
    ------
    typer.Exit
        Two input files of different arms, or ``--model`` naming another arm
        than an input file (one line naming both, exit 2).
    """
    named = [r for r in recorded if r.model is not None and str(r.model).strip()]
    first = named[0] if named else None
    for other in named[1:]:
        assert first is not None and first.model is not None and other.model is not None
        if not same(first.model, other.model):
            fail(
                f"{first.source} is of {a_or_an(first.model)} but {other.source} of "
                f"{a_or_an(other.model)}: "
                "give files of one arm"
            )
    if first is None or first.model is None:
        return given if given is not None else default
    if given is not None and not same(given, first.model):
        fail(
            f"--model {given} but {first.source} is of {a_or_an(first.model)}: leave --model out "
            "(the file names its arm) or give files of that arm"
        )
    return first.model


def calibration(cal: Any, path: str | PathLike[str], given: str | None) -> Any:
    """``cal`` naming its arm: its own ``model``, else ``--model`` (checked against its table).

    Parameters
    ----------
    cal : calibrator.calibration.Calibration
    path : str or path-like
        The calibration's file, for messages.
    given : str or None
        ``--model``.

    Returns
    -------
    calibrator.calibration.Calibration
        ``cal`` itself when it names an arm or no ``--model`` is given; else a
        copy whose ``model`` is ``--model`` (its nominal table must be that
        arm's).

    Raises
    ------
    typer.Exit
        ``--model`` naming another arm than the file (exit 2).
    calibrator.errors.CalibrationError
        An unknown ``--model``, or one whose table is not the calibration's.
    """
    name = resolve(given, From(cal.model, path), default=None)
    if name is None or cal.model is not None:
        return cal
    from calibrator import robots
    from calibrator.model import consistency

    arm = robots.get(name)
    consistency.check_model_table(
        name, arm.mdh, cal.nominal_mdh, f"{path}: 'nominal_mdh' (--model {given})"
    )
    return replace(cal, model=arm.name)
