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
  as :mod:`calibrator.filtering.configuration` reads them.
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

from calibrator.filtering import configuration, rotations
from calibrator.filtering.base import (
    Language,
    Layout,
    Target,
    Unit,
    language,
    numbered_frame,
    read_lines,
    target_tool,
)
from calibrator.model import frames

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_START = re.compile(r"^\s*P\[(\d+)(?::\"[^\"]*\")?\]\s*\{")
_VALUE = re.compile(r"\b(X|Y|Z|W|P|R|J[1-6])\s*=\s*(" + _NUM + ")")
_FRAMES = re.compile(r"\bUF\s*:\s*(\d+)\s*,\s*UT\s*:\s*(\d+)")
_CONFIG = re.compile(
    r"CONFIG\s*:\s*'([NF])\s*([UD])\s*([TB])\s*,\s*([+-]?\d+)\s*,\s*([+-]?\d+)\s*,\s*([+-]?\d+)\s*'"
)

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
        for number, line in read_lines(path):
            stripped = line.strip()
            if not block:
                if stripped.startswith("/"):
                    in_pos = stripped.startswith("/POS")
                if in_pos and _START.match(line):
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
            yield self._unit(path, first, block)

    def _unit(self, path, first, lines):
        unit = Unit(lines)
        label = "P[" + _START.match(lines[0]).group(1) + "]"
        in_gp1 = False
        found: dict = {}
        uf = ut = None
        config = None
        for li, line in enumerate(lines):
            group = re.search(r"\bGP(\d+)\s*:", line)
            if group:
                in_gp1 = group.group(1) == "1"
            if not in_gp1:
                continue
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
                found.setdefault(m.group(1), (m.group(2), li, m.start(2), m.end(2)))
        joints = all(k in found for k in JOINT_KEYS)
        keys = JOINT_KEYS if joints else POSE_KEYS
        if not joints and not all(k in found for k in POSE_KEYS):
            return unit  # no group-1 position to correct
        target = Target(
            file=str(path), line=first + found[keys[0]][1], label=label,
            layout=JOINTS if joints else POSE,
            tokens=[found[k][0] for k in keys],
            spans=[found[k][1:] for k in keys], code=None if joints else config,
        )  # fmt: skip
        target.tool, p1 = target_tool(self.job, joints, self._frame("tool", ut))
        target.base, p2 = (None, None) if joints else self._frame("base", uf)
        target.problem = p1 or p2
        if not joints and config is None:
            target.problem = target.problem or "a Cartesian position without CONFIG"
        unit.targets.append(target)
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
