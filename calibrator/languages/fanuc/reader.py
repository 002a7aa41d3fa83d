"""Fanuc LS (ASCII TP programs): the ``/POS`` section's positions of group 1.

Read from Fanuc's TP programming references (the ``.ls`` listing):

- Each position is a block ``P[n]{ ... };`` (``P[n:"comment"]{`` too) in
  ``/POS``; group ``GP1:`` holds ``UF : u, UT : t,`` and either
  ``CONFIG : 'N U T, 0, 0, 0',`` with ``X = .. mm, Y, Z, W = .. deg, P, R``
  (Cartesian, in user frame ``u`` with tool ``t``) or ``J1= .. deg`` ... ``J6``
  (joints). Other groups (positioners) and extended axes are kept.
- ``W, P, R`` are rotations about the fixed X, Y, Z axes: ``Rz(R) Ry(P) Rx(W)``.
- ``CONFIG``: wrist ``N``/``F`` (flip: joint 5 negative), elbow ``U``/``D``,
  arm ``T``/``B`` (wrist centre in front of / behind axis 1), then the turn
  numbers of joints 1, 4 and 6 (0 on (-180, 180] deg, 1 on (180, 540], ...),
  as :mod:`calibrator.languages.configuration` reads them.
- User frame 0 is the world (robot base) frame and tool 0 the faceplate;
  other ``UF``/``UT`` numbers come from ``--frames`` (``bases``/``tools``
  named by their number).

The ``/POS`` section has no comments: ``--keep-failed`` leaves failed
positions unchanged without a mark.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from calibrator.languages import configuration, numbers
from calibrator.languages.lexing import Lexer
from calibrator.languages.reading import (
    FilterError,
    Language,
    Layout,
    Target,
    Unit,
    language,
    numbered_frame,
    read_lines,
    target_tool,
)
from calibrator.model import frames, rotations

_START = re.compile(r"^\s*P\[(\d+)(?::\"[^\"]*\")?\]\s*\{")
# A value is the whole field after ``=`` (up to blanks or a comma): checked by
# the number grammar, never read as the number at its start (``1.2.3``).
_VALUE = re.compile(r"\b(X|Y|Z|W|P|R|J[1-6])\s*=[ \t]*([^\s,;]*)")
_UNIT = re.compile(r"[ \t]*(mm|deg)\b")
_FRAMES = re.compile(r"\bUF\s*:\s*(\d+)\s*,\s*UT\s*:\s*(\d+)")
_CONFIG = re.compile(
    r"CONFIG\s*:\s*'([NF])\s*([UD])\s*([TB])\s*,\s*([+-]?\d+)\s*,\s*([+-]?\d+)\s*,\s*([+-]?\d+)\s*'"
)

#: Strings are comments (``P[3:"X = 5"]``); the /POS section has no other comments.
_LEXER = Lexer(quotes='"')

POSE_KEYS = ("X", "Y", "Z", "W", "P", "R")
JOINT_KEYS = tuple(f"J{i}" for i in range(1, 7))


def _decode_pose(v):
    return frames.transform(rotations.zyx_to_matrix(v[:, [5, 4, 3]]), v[:, :3])


def _encode_pose(pose, old):
    rpw = rotations.matrix_to_zyx(pose[:, :3, :3], old[:, [5, 4, 3]])
    return np.concatenate([pose[:, :3, 3], rpw[:, [2, 1, 0]]], axis=1)


POSE = Layout("pose", ("mm",) * 3 + ("deg",) * 3, _decode_pose, _encode_pose)
JOINTS = Layout("joints", ("deg",) * 6, np.radians, lambda q, old: np.degrees(q))


@language("fanuc", (".ls",), "Fanuc LS /POS positions (mm, deg; W-P-R, CONFIG)")
class FanucLS(Language):
    comment = None

    def scan(self, path: Path) -> Iterator[Unit]:
        in_pos = False
        block: list = []
        first = 0
        seen: dict[int, int] = {}  # position number -> its line
        for number, line in read_lines(path):
            stripped = line.strip()
            if not block:
                if stripped.startswith("/"):
                    in_pos = stripped.startswith("/POS")
                start = _START.match(line) if in_pos else None
                if start:
                    n = int(start.group(1))
                    if n in seen:
                        raise FilterError(
                            f"{path}:{number}: P[{n}] is defined again (first on line "
                            f"{seen[n]}); which one the program moves to is unclear"
                        )
                    seen[n] = number
                    block, first = [line], number
                    if stripped.endswith("};"):
                        yield self._unit(path, first, block)
                        block = []
                    continue
                yield Unit([line])
                continue
            block.append(line)
            if stripped.startswith("};"):
                yield self._unit(path, first, block)
                block = []
        if block:
            yield self._unit(path, first, block, closed=False)

    def _unit(self, path, first, lines, closed=True):
        unit = Unit(lines)
        label = "P[" + _START.match(lines[0]).group(1) + "]"
        in_gp1 = False
        found: dict = {}
        twice: list = []
        saw_gp1 = False
        uf = ut = None
        config = None
        for li, raw in enumerate(lines):
            line = _LEXER.code(raw)  # a comment P[1:"X = 5"] holds no value
            group = re.search(r"\bGP(\d+)\s*:", line)
            if group:
                in_gp1 = group.group(1) == "1"
            if not in_gp1:
                continue
            saw_gp1 = True
            f = _FRAMES.search(line)
            if f:
                uf, ut = int(f.group(1)), int(f.group(2))
            c = _CONFIG.search(line)
            if c:
                config = (
                    int(c.group(1) == "F"), int(c.group(2) == "D"), int(c.group(3) == "B"),
                    int(c.group(4)), int(c.group(5)), int(c.group(6)),
                )  # fmt: skip
            for m in _VALUE.finditer(line):
                if m.group(1) in found:
                    twice.append(m.group(1))
                    continue
                token = m.group(2)
                if _UNIT.fullmatch(" " + token):
                    token = ""  # ``X = mm``: the number itself is missing
                    found[m.group(1)] = (token, li, m.start(2), m.start(2))
                else:
                    found[m.group(1)] = (token, li, m.start(2), m.end(2))
        if not saw_gp1:
            return unit  # positions of other groups only: nothing of the arm's
        joints = any(k in found for k in JOINT_KEYS)
        keys = JOINT_KEYS if joints else POSE_KEYS
        missing = [k for k in keys if k not in found]
        li0 = found[keys[0]][1] if keys[0] in found else 0
        target = Target(
            file=str(path), line=first + li0, label=label,
            layout=JOINTS if joints else POSE,
            tokens=[found[k][0] for k in keys] if not missing else ["0"] * 6,
            spans=[found[k][1:] for k in keys] if not missing else [],
            code=None if joints else config,
        )  # fmt: skip
        unit.targets.append(target)
        # A group-1 position the reader cannot read whole fails (never skipped).
        bad = numbers.first_problem(target.tokens) if not missing else None
        mixed = joints and any(k in found for k in POSE_KEYS)
        if missing or bad or twice or mixed or not closed:
            target.tokens = ["0"] * 6
            target.spans = []
            target.problem = (
                (f"{label} is not closed by '}};'" if not closed else None)
                or (f"no {', '.join(missing)} in group 1" if missing else None)
                or bad
                or (f"{twice[0]} is given twice" if twice else None)
                or "both joint and Cartesian values in group 1"
            )
            return unit
        target.tool, p1 = target_tool(self.job, joints, self._frame("tool", ut))
        target.base, p2 = (None, None) if joints else self._frame("base", uf)
        target.problem = p1 or p2
        if not joints and config is None:
            target.problem = target.problem or "a Cartesian position without CONFIG"
        return unit

    def _frame(self, kind, number):
        if number is None:
            return None, f"no {'UT' if kind == 'tool' else 'UF'} number"
        frame = numbered_frame(self.job, kind, number)
        if frame is not None:
            return frame, None
        what = "tool frame UT" if kind == "tool" else "user frame UF"
        return None, f"{what} {number} is not in --frames"

    def code(self, q_deg: np.ndarray, bits: np.ndarray) -> np.ndarray:
        b = np.asarray(bits)
        q = np.asarray(q_deg)
        return np.column_stack(
            [b[:, 2], b[:, 1], b[:, 0], configuration.turn(q[:, 0]),
             configuration.turn(q[:, 3]), configuration.turn(q[:, 5])]
        )  # fmt: skip

    def code_bits(self, code: np.ndarray) -> np.ndarray:
        c = np.asarray(code)
        return np.column_stack([c[:, 2], c[:, 1], c[:, 0]])

    def describe(self, code: tuple) -> str:
        f, d, b, t1, t4, t6 = code
        return f"'{'NF'[f]} {'UD'[d]} {'TB'[b]}, {t1}, {t4}, {t6}'"
