"""Yaskawa Motoman INFORM jobs (``.jbi``): the ``//POS`` section's robot positions.

Read from Yaskawa's job file format (DX/YRC controllers' ``.JBI``):

- ``//POS`` lists positions ``C00000=v1,v2,...``; the header lines before them
  say how to read them, until the next header: ``///TOOL n``, ``///USER n``,
  ``///POSTYPE PULSE|BASE|ROBOT|USER``, ``///PULSE`` or ``///RECTAN`` and
  ``///RCONF l,m,n,o,p,q,r,s``. Only ``C`` (robot) positions are read;
  ``BC``/``EC`` (base and station axes) and ``P`` variables are kept.
- Pulse positions are joint encoder counts: ``deg = (pulse - zero) / pulses_per_degree``,
  the scale from ``--frames`` (``pulses_per_degree``, ``zero_pulses``; the
  arm's description once it carries them). Without a scale they cannot be
  read and fail when they would be corrected.
- Rectangular positions are ``X, Y, Z`` (mm) and ``Rx, Ry, Rz`` (deg, about
  the fixed X, Y, Z: ``Rz Ry Rx``), in the robot base (``BASE``/``ROBOT``;
  no travel axis) or user frame ``USER n`` (from ``--frames`` ``bases``), for
  tool ``n`` (``--frames`` ``tools``; tool 0 is the flange).
- ``RCONF`` is read as ``flip, lower arm (elbow down), back, R >= 180, T >= 180, S >= 180``
  (the last two flags are kept as they are): joint 5 negative is flip, and
  the R, T, S flags are joints 4, 6 and 1 beyond half a turn
  (:mod:`calibrator.languages.configuration`).

Positions have no comments: ``--keep-failed`` leaves failed positions
unchanged without a mark.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from calibrator.languages import configuration, numbers
from calibrator.languages.reading import (
    FilterError,
    Job,
    Language,
    Layout,
    Target,
    Unit,
    language,
    numbered_frame,
    read_lines,
    split_ending,
    target_tool,
)
from calibrator.model import frames, rotations

_POSITION = re.compile(r"^(C\d+)=(.*)$")


def _decode_pose(v):
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


def _encode_pose(pose, old):
    rpw = rotations.matrix_to_zyx(pose[:, :3, :3], old[:, [5, 4, 3]])
    return np.concatenate([pose[:, :3, 3], rpw[:, [2, 1, 0]]], axis=1)


POSE = Layout("pose", ("mm",) * 3 + ("deg",) * 3, _decode_pose, _encode_pose)


@language("jbi", (".jbi",), "Yaskawa Motoman INFORM job (pulses; mm, deg, RCONF)")
class JBI(Language):
    comment = None

    def __init__(self, job: Job, program: Path) -> None:
        super().__init__(job, program)
        ppd = job.frames.pulses_per_degree
        zero = job.frames.zero_pulses
        self.pulses = None
        if ppd is not None:
            zero = np.zeros(6) if zero is None else zero
            self.pulses = Layout(
                "joints", ("pulse",) * 6,
                lambda v: np.radians((v - zero) / ppd),
                lambda q, old: np.degrees(q) * ppd + zero,
            )  # fmt: skip
        self.unscaled = Layout(
            "joints", ("pulse",) * 6, lambda v: np.full((len(v), 6), np.nan), lambda q, old: old
        )

    def scan(self, path: Path) -> Iterator[Unit]:
        in_pos = False
        tool = user = 0
        postype, rectan, rconf = "PULSE", False, None
        seen: dict[str, int] = {}
        for number, line in read_lines(path):
            body, _ = split_ending(line)
            unit = Unit([line])
            head = body.strip().upper()
            if head.startswith("//") and not head.startswith("///"):
                in_pos = head.startswith("//POS")
            elif in_pos and head.startswith("///"):
                word, _, rest = head[3:].partition(" ")
                if word == "TOOL":
                    tool = _header_int(rest, path, number, "TOOL")
                elif word == "USER":
                    user = _header_int(rest, path, number, "USER")
                elif word == "POSTYPE":
                    postype = rest.strip()
                elif word == "PULSE":
                    rectan = False
                elif word == "RECTAN":
                    rectan = True
                elif word == "RCONF":
                    rconf = tuple(_header_int(v, path, number, "RCONF") for v in rest.split(","))
            elif in_pos:
                m = _POSITION.match(body)
                if m:
                    label = m.group(1).upper()
                    if label in seen:
                        raise FilterError(
                            f"{path}:{number}: position {m.group(1)} is defined again "
                            f"(first on line {seen[label]}); which one is meant is unclear"
                        )
                    seen[label] = number
                    unit.targets.append(
                        self._target(path, number, m, tool, user, postype, rectan, rconf)
                    )
            yield unit

    def _target(self, path, number, m, tool_no, user_no, postype, rectan, rconf):
        # Every comma-separated field is a number (a malformed one fails the
        # position: read as two numbers it would shift the columns after it).
        nums = numbers.fields(m.group(2), m.start(2))
        layout = POSE if rectan else (self.pulses or self.unscaled)
        target = Target(
            file=str(path), line=number, label=m.group(1), layout=layout,
            tokens=[t for t, _, _ in nums[:6]], spans=[(0, s, e) for _, s, e in nums[:6]],
        )  # fmt: skip
        bad = numbers.first_problem(nums)
        if len(nums) < 6 or bad is not None:
            target.tokens = ["0"] * 6
            target.problem = bad or f"{len(nums)} values, a position has 6"
            return target
        target.tool, problem = target_tool(self.job, not rectan, self._frame("tool", tool_no))
        if rectan:
            if postype == "USER":
                target.base, p2 = self._frame("base", user_no)
                problem = problem or p2
            elif postype not in ("BASE", "ROBOT"):
                problem = problem or f"rectangular position of POSTYPE {postype}"
            if rconf is None or len(rconf) < 6:
                problem = problem or "a rectangular position without RCONF"
            else:
                target.code = rconf[:6]
        elif self.pulses is None and self.job.correct_joints:
            problem = problem or "pulse positions need pulses_per_degree in --frames"
        target.problem = problem
        return target

    def _frame(self, kind, number):
        frame = numbered_frame(self.job, kind, number)
        if frame is not None:
            return frame, None
        return None, f"{'TOOL' if kind == 'tool' else 'USER'} {number} is not in --frames"

    def code(self, q_deg: np.ndarray, bits: np.ndarray) -> np.ndarray:
        b = np.asarray(bits)
        q = np.asarray(q_deg)
        return np.column_stack(
            [b[:, 2], b[:, 1], b[:, 0], configuration.beyond_half_turn(q[:, 3]),
             configuration.beyond_half_turn(q[:, 5]), configuration.beyond_half_turn(q[:, 0])]
        )  # fmt: skip

    def code_bits(self, code: np.ndarray) -> np.ndarray:
        c = np.asarray(code)
        return np.column_stack([c[:, 2], c[:, 1], c[:, 0]])

    def describe(self, code: tuple) -> str:
        return "RCONF " + ",".join(str(c) for c in code)


def _header_int(text: str, path: Path, number: int, word: str) -> int:
    """A whole number of a ``///`` header (``TOOL 1``, ``RCONF 0,0,...``), or one line naming it."""
    token = text.strip()
    if not re.fullmatch(r"[+-]?\d{1,9}", token):
        raise FilterError(f"{path}:{number}: ///{word}: {token[:40]!r} is not a whole number")
    return int(token)
