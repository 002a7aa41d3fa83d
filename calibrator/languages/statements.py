"""What every language's program says alike: the title, and the moves between the homes."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from calibrator.inputs import messages
from calibrator.languages.spec import PULSE_S, ProgramSpec

__all__ = ["between_homes", "title"]


def title(spec: ProgramSpec) -> str:
    """The header line every program opens with: its poses, and the model when known."""
    model = f" of {messages.a_or_an(spec.model)}" if spec.model else ""
    return f"{len(spec.plan_rad)} poses for a laser-tracker calibration{model}"


def between_homes(
    spec: ProgramSpec,
    move: Callable[[str, int, np.ndarray, np.ndarray], str],
    pulse: Callable[[int], list[str]],
    dwell: Callable[[float], str],
    *,
    comment: Callable[[str], str] | None = None,
    pulse_blocks: bool = False,
) -> list[str]:
    """The statements between the first and the last home move, in every language.

    Per via (moved through on the path the plan checked in the cell) its move
    alone; per pose its move, the pulse if asked and the dwell. Each language
    gives its own statements.

    Parameters
    ----------
    spec : ProgramSpec
    move : callable
        ``move(kind, pose, start_rad, end_rad)`` (``kind`` ``"via"`` or ``"pose"``,
        joints shape (6,), rad): the joint move statement.
    pulse : callable
        ``pulse(output)``: the statements pulsing the digital output for :data:`PULSE_S`.
    dwell : callable
        ``dwell(seconds)``: the wait statement.
    comment : callable, optional
        ``comment(text)``: a comment line, written before each move
        (``via before pose i`` or ``pose i``); None: no comments.
    pulse_blocks : bool
        The pulse statements wait out the pulse, so the dwell is that much shorter.

    Returns
    -------
    list of str
    """
    lines: list[str] = []
    for kind, pose, start, end in spec.moves()[1:-1]:
        assert pose is not None  # only the home moves have no pose
        if comment is not None:
            lines.append(comment(f"via before pose {pose}" if kind == "via" else f"pose {pose}"))
        lines.append(move(kind, pose, start, end))
        if kind == "via":
            continue  # no dwell, no pulse
        wait = spec.dwell_s
        if spec.pulse_output is not None:
            lines += pulse(spec.pulse_output)
            if pulse_blocks:
                wait -= PULSE_S
        lines.append(dwell(wait))
    return lines
