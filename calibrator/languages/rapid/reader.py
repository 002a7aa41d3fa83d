"""ABB RAPID modules (``.mod``, ``.prg``, ``.modx``): robtargets and jointtargets.

Read from ABB's RAPID reference (instructions and data types):

- ``robtarget``: ``[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx], [eax_a, ..., eax_f]]``,
  mm and a unit quaternion ``[w, x, y, z]``, the TCP's pose in the object
  frame of the work object the move names. ``jointtarget``:
  ``[[rax_1, ..., rax_6], [eax_a, ..., eax_f]]`` in deg.
- Declared (``CONST``/``PERS``/``VAR robtarget p10 := [...];``, also ``LOCAL``
  or ``TASK``) or written inline as the target of ``MoveJ``, ``MoveL``,
  ``MoveC`` (circle point and target) and ``MoveAbsJ``. Their tool and work
  object are the move's: ``MoveL p10, v100, z10, tool1\\WObj:=wobj1;``
  (``wobj0`` when none, ``tool0`` is the flange).
- ``tooldata`` ``[robhold, [[x, y, z], [q]], loaddata]`` and ``wobjdata``
  ``[robhold, ufprog, ufmec, [[x, y, z], [q]] (uframe), [[x, y, z], [q]] (oframe)]``
  declared in the module define the frames (the object frame in the world is
  ``uframe @ oframe``); any other comes from ``--frames``. A stationary tool
  (``robhold`` FALSE) or a work object held by the robot or moved by a
  mechanical unit cannot be corrected here: such targets fail.
- ``confdata``: cf1, cf4, cf6 are the quadrants of axes 1, 4, 6 (``floor(q / 90 deg)``)
  and cfx is ``4 * back + 2 * elbow down + flip``
  (:mod:`calibrator.languages.configuration`).

A statement may span lines (it ends at ``;``); ``!`` starts a comment.
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
    Job,
    Language,
    Layout,
    Target,
    Unit,
    language,
    read_lines,
    split_ending,
    target_tool,
)
from calibrator.model import frames, rotations

_DECL = re.compile(
    r"^\s*(?:LOCAL\s+|TASK\s+)*(?:CONST|PERS|VAR)\s+(robtarget|jointtarget|tooldata|wobjdata)"
    r"\s+([A-Za-z]\w*)\s*:=\s*\[",
    re.IGNORECASE,
)
_MOVE = re.compile(r"\b(MoveAbsJ|MoveJ|MoveL|MoveC)\b\s*", re.IGNORECASE)
_WOBJ = re.compile(r"\\WObj\s*:=\s*([A-Za-z]\w*)", re.IGNORECASE)


def _decode_pose(v):
    return frames.transform(rotations.quaternion_to_matrix(v[:, 3:7]), v[:, :3])


def _encode_pose(pose, old):
    return np.concatenate(
        [pose[:, :3, 3], rotations.matrix_to_quaternion(pose[:, :3, :3], old[:, 3:7])], axis=1
    )


POSE = Layout("pose", ("mm",) * 3 + ("quat",) * 4, _decode_pose, _encode_pose)
JOINTS = Layout("joints", ("deg",) * 6, np.radians, lambda q, old: np.degrees(q))


#: RAPID's strings ("...") and ``!`` comments: neither holds a target nor a bracket.
_LEXER = Lexer(quotes='"', comment="!")


def _code(text: str) -> str:
    """A RAPID line's code: strings and the comment blanked, every position kept."""
    return _LEXER.code(text)


def _statements(path: Path):
    """``(first line number, [lines], joined code, [offset of each line in it])`` per statement."""
    lines: list[str] = []
    offsets: list[int] = []
    code, first, depth = "", 0, 0
    for number, line in read_lines(path):
        if not lines:
            first = number
        body, _ = split_ending(line)
        offsets.append(len(code))
        part = _code(body)
        code += part + "\n"
        lines.append(line)
        # An aggregate may go on over lines; a statement ends where its brackets close.
        depth += part.count("[") + part.count("(") - part.count("]") - part.count(")")
        # A statement ends at its ``;`` (outside strings: they are blanked) even
        # where its brackets do not close: a line cut short spoils one statement,
        # never the rest of the module.
        if depth <= 0 or ";" in part:
            yield first, lines, code, offsets
            lines, offsets, code, depth = [], [], "", 0
    if lines:
        yield first, lines, code, offsets


def _bracket_end(code: str, start: int) -> int:
    depth = 0
    for i in range(start, len(code)):
        if code[i] == "[":
            depth += 1
        elif code[i] == "]":
            depth -= 1
            if depth == 0:
                return i + 1
    return len(code)


def _split_args(code: str, start: int) -> list[tuple[int, int]]:
    """Top-level comma-separated arguments from ``start`` to the statement's ``;``."""
    depth, begin, out = 0, start, []
    for i in range(start, len(code)):
        ch = code[i]
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        elif ch in ",;" and depth == 0:
            out.append((begin, i))
            begin = i + 1
            if ch == ";":
                break
    return out


#: One field of an aggregate: what stands between ``[`` or ``,`` and ``,`` or ``]``.
_ITEM = re.compile(r"(?<=[\[,])([^\[\],]*)(?=[\],])")


def _numbers(code: str, start: int, end: int):
    """Every field of the aggregate in ``code[start:end]``: ``(token, start, end)``, stripped.

    Fields are taken whole, so that the number grammar judges each one
    (``1.2.3`` is one bad field, never two numbers shifting the rest).
    """
    out = []
    for m in _ITEM.finditer(code, start, end):
        text = m.group(1)
        lead = len(text) - len(text.lstrip())
        token = text.strip()
        out.append((token, m.start(1) + lead, m.start(1) + lead + len(token)))
    return out


def _locate(pos: int, offsets: list) -> tuple[int, int]:
    li = int(np.searchsorted(offsets, pos, side="right")) - 1
    return li, pos - offsets[li]


def _move_args(code: str, m) -> dict:
    """Targets, tool and work object of a move: {'targets': [(start, end)], 'tool', 'wobj'}."""
    args = [a for a in _split_args(code, m.end()) if not code[a[0] : a[1]].strip().startswith("\\")]
    n_targets = 2 if m.group(1).lower() == "movec" else 1
    out = {"targets": args[:n_targets], "tool": None, "wobj": "wobj0"}
    if len(args) >= n_targets + 3:
        tool_arg = code[args[n_targets + 2][0] : args[n_targets + 2][1]]
        out["tool"] = tool_arg.split("\\")[0].strip().lower()
        w = _WOBJ.search(tool_arg)
        if w:
            out["wobj"] = w.group(1).lower()
    return out


@language("rapid", (".mod", ".prg", ".modx"), "ABB RAPID module (mm, quaternion, confdata)")
class RAPID(Language):
    comment = "!"

    def __init__(self, job: Job, program: Path) -> None:
        super().__init__(job, program)
        self.tools: dict = {"tool0": np.eye(4)}
        self.wobjs: dict = {"wobj0": np.eye(4)}
        self.problems: dict = {}
        self.uses: dict = {}
        declared: dict[str, int] = {}
        for number, _, code, _ in _statements(self.program):
            decl = _DECL.match(code)
            if decl:
                # RAPID ignores case: p10 and P10 are one name, declared twice.
                key = decl.group(2).lower()
                if key in declared:
                    raise FilterError(
                        f"{program}:{number}: {decl.group(2)} is declared again (first on line "
                        f"{declared[key]}); which one is moved to is unclear"
                    )
                declared[key] = number
            if decl and decl.group(1).lower() in ("tooldata", "wobjdata"):
                self._frame_decl(decl, code, f"{program}:{number}")
            for m in _MOVE.finditer(code):
                args = _move_args(code, m)
                for a, b in args["targets"]:
                    name = code[a:b].strip().split("\\")[0].strip()
                    if not re.fullmatch(r"[A-Za-z]\w*", name):
                        continue
                    key, now = name.lower(), (args["tool"], args["wobj"], number)
                    seen = self.uses.get(key)
                    if seen is not None and seen[:2] != now[:2]:
                        raise FilterError(
                            f"{program}:{number}: {name} is moved to with {now[0]}, {now[1]} here "
                            f"and {seen[0]}, {seen[1]} on line {seen[2]}; one target cannot be "
                            f"corrected for two frames"
                        )
                    self.uses[key] = now

    def _frame_decl(self, decl, code, where):
        kind, name = decl.group(1).lower(), decl.group(2).lower()
        body = code[decl.end() - 1 : _bracket_end(code, decl.end() - 1)]
        fields = _numbers(body, 0, len(body))
        flags = [t for t, _, _ in fields if t.upper() in ("TRUE", "FALSE")]
        values = [f for f in fields if f[0].upper() not in ("TRUE", "FALSE") and f[0][:1] != '"']
        bad = numbers.first_problem(values)
        if bad is not None:
            raise FilterError(f"{where}: {kind} {name}: {bad}")
        nums = [float(t) for t, _, _ in values]
        if kind == "tooldata":
            if flags and flags[0].upper() == "FALSE":
                self.problems[("tool", name)] = f"tool {name} is stationary (robhold FALSE)"
            if len(nums) < 7:
                raise FilterError(f"{where}: tooldata {name} has no tframe")
            self.tools[name] = _decode_pose(np.array([nums[:7]]))[0]
        else:
            if len(flags) >= 2 and (flags[0].upper() == "TRUE" or flags[1].upper() == "FALSE"):
                self.problems[("wobj", name)] = (
                    f"work object {name} is held by the robot or moved by a mechanical unit"
                )
            if len(nums) < 14:
                raise FilterError(f"{where}: wobjdata {name} lacks uframe or oframe")
            uf, of = _decode_pose(np.array([nums[:7], nums[7:14]]))
            self.wobjs[name] = uf @ of

    def _frame(self, kind: str, name: str | None):
        if name is None:
            return None, "the move names no tool"
        if (kind, name) in self.problems:
            return None, self.problems[(kind, name)]
        local = self.tools if kind == "tool" else self.wobjs
        if name in local:
            return local[name], None
        table = self.job.frames.tools if kind == "tool" else self.job.frames.bases
        if name in table:
            return table[name], None
        what = "tooldata" if kind == "tool" else "wobjdata"
        return None, f"{what} {name} is defined neither in the module nor in --frames"

    def scan(self, path: Path) -> Iterator[Unit]:
        for number, lines, code, offsets in _statements(path):
            unit = Unit(lines)
            decl = _DECL.match(code)
            if decl and decl.group(1).lower() in ("robtarget", "jointtarget"):
                use = self.uses.get(decl.group(2).lower())
                if use is not None:
                    start = decl.end() - 1
                    joints = decl.group(1).lower() == "jointtarget"
                    name = decl.group(2)
                    unit.targets.append(
                        self._target(path, number, name, joints, code, start, offsets, *use[:2])
                    )
            else:
                for m in _MOVE.finditer(code):
                    args = _move_args(code, m)
                    for a, _ in args["targets"]:
                        lead = code[a:].lstrip()
                        if not lead.startswith("["):
                            continue
                        start = a + (len(code[a:]) - len(lead))
                        joints = m.group(1).lower() == "moveabsj"
                        unit.targets.append(
                            self._target(path, number, m.group(1), joints, code, start, offsets,
                                         args["tool"], args["wobj"])
                        )  # fmt: skip
            yield unit

    def _target(self, path, number, label, joints, code, start, offsets, tool_name, wobj_name):
        nums = _numbers(code, start, _bracket_end(code, start))
        need = 6 if joints else 11
        target = Target(
            file=str(path), line=number, label=label, layout=JOINTS if joints else POSE,
            tokens=[], spans=[],
        )  # fmt: skip
        bad = numbers.first_problem(nums)
        if len(nums) < need or bad is not None:
            target.tokens = ["0"] * (6 if joints else 7)
            target.problem = bad or "an incomplete target"
            return target
        used = nums[:6] if joints else nums[:7]
        target.tokens = [t for t, _, _ in used]
        target.spans = []
        for _, s, e in used:
            li, col = _locate(s, offsets)
            target.spans.append((li, col, col + (e - s)))
        target.line = number + target.spans[0][0]
        target.mark_line = len(offsets) - 1
        tool, p1 = target_tool(self.job, joints, self._frame("tool", tool_name))
        base, p2 = (None, None) if joints else self._frame("wobj", wobj_name)
        target.tool, target.base, target.problem = tool, base, p1 or p2
        if not joints:
            if not all(re.fullmatch(r"[+-]?\d{1,9}", t) for t, _, _ in nums[7:11]):
                target.problem = target.problem or "a confdata value is not a whole number"
            else:
                target.code = tuple(int(t) for t, _, _ in nums[7:11])
        return target

    def code(self, q_deg: np.ndarray, bits: np.ndarray) -> np.ndarray:
        b = np.asarray(bits)
        q = np.asarray(q_deg)
        return np.column_stack(
            [configuration.quadrant(q[:, 0]), configuration.quadrant(q[:, 3]),
             configuration.quadrant(q[:, 5]), 4 * b[:, 0] + 2 * b[:, 1] + b[:, 2]]
        )  # fmt: skip

    def code_bits(self, code: np.ndarray) -> np.ndarray:
        cfx = np.asarray(code)[:, 3]
        return np.column_stack([(cfx >> 2) & 1, (cfx >> 1) & 1, cfx & 1])

    def describe(self, code: tuple) -> str:
        return "[" + ",".join(str(c) for c in code) + "]"
