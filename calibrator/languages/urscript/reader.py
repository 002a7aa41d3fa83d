"""URScript (Universal Robots): ``movej``/``movel``/``movep``/``movec`` targets.

Read from the URScript manual: a pose ``p[x, y, z, rx, ry, rz]`` is in m
and a rotation vector (rad), in the robot base frame, for the TCP set by the
last ``set_tcp(p[...])`` (the flange when none); a joint list ``[q1, ..., q6]``
is in rad. A move's target is its first argument (``movec``: its first two),
written inline or as a variable assigned ``name = p[...]`` (or ``[...]``) on
its own line. The controller solves a pose target nearest the joints it
comes from, so a pose keeps the configuration of the target before it.

A variable moved to under two different TCPs cannot be corrected for both:
the reader refuses it, naming both lines. Everything after ``#`` is a
comment.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

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
    read_chunks,
    split_ending,
)
from calibrator.model import frames, rotations

_MOVE = re.compile(r"\b(movej|movel|movep|movec)\s*\(")
#: A move of something other than a literal list, or text that may read so (a superset:
#: no word boundary, and a line break counts as not a literal; fast, with no alternation).
_MOVE_NOT_LITERAL = re.compile(r"move[jlpc]\s*\((?![ \t]*p?[ \t]*\[)")
_TCP = re.compile(r"\bset_tcp\s*\(\s*p\s*\[([^\]]*)\]")
_ASSIGN_START = re.compile(r"^\s*(?:global\s+|local\s+)?([A-Za-z_]\w*)\s*=\s*(p?)\s*\[")
_UNCLOSED = "its list is not closed on its line"
_OPENED = re.compile(r"\s*(p?)\s*\[")
_ASSIGN = re.compile(r"^\s*(?:global\s+|local\s+)?([A-Za-z_]\w*)\s*=\s*(p?)\s*\[([^\]]*)\]\s*$")
#: One field of the plain line below: a number of :data:`numbers.PLAIN`'s grammar (always
#: finite, so it passes :func:`numbers.problem`), blanks around it. Possessive quantifiers
#: throughout: no part of the pattern can take what the next part needs, so none gives back.
_FIELD = r"[ \t]*+(" + numbers.PLAIN_POSSESSIVE + r")[ \t]*+"
#: The usual line of a long program, read with one match: a ``movej``/``movel``/``movep``
#: of an inline literal of six plain numbers, more arguments that hold no string, comment,
#: bracket or call, nothing else on the line. It holds no ``set_tcp`` and no variable, so
#: it reads as the general path would read it; any other line takes the general path.
_PLAIN_MOVE = re.compile(
    r"[ \t]*+(movej|movel|movep)[ \t]*+\([ \t]*+(p?)[ \t]*+\["
    + ",".join([_FIELD] * 6)
    + r"\][ \t]*+(?:,[^\[\]()\"'#]*+)?\)[ \t]*+(?:\r\n|\n|\r)?"
)


def _decode_pose(v):
    return frames.transform(rotations.rotvec_to_matrix(v[:, 3:]), 1000.0 * v[:, :3])


def _encode_pose(pose, old):
    rv = rotations.matrix_to_rotvec(pose[:, :3, :3])
    # r and r - 2 pi r/|r| are the same rotation: keep the one nearer the program's.
    angle = np.linalg.norm(rv, axis=1, keepdims=True)
    alt = rv - 2.0 * np.pi * rv / np.maximum(angle, 1e-12)
    pick = np.linalg.norm(alt - old[:, 3:], axis=1) < np.linalg.norm(rv - old[:, 3:], axis=1)
    rv = np.where(pick[:, None], alt, rv)
    return np.concatenate([pose[:, :3, 3] / 1000.0, rv], axis=1)


POSE = Layout("pose", ("m",) * 3 + ("rad",) * 3, _decode_pose, _encode_pose)
JOINTS = Layout("joints", ("rad",) * 6, lambda v: v, lambda q, old: q)


#: URScript's strings ("..." and '...') and its ``#`` comments: neither holds a target.
_LEXER = Lexer(quotes="\"'", comment="#")


def _code_part(body: str) -> str:
    """The line's code: strings and the comment blanked, every position kept."""
    return _LEXER.code(body)


def _numbers_in(text: str, offset: int) -> list[tuple[str, int, int]]:
    """The comma-separated fields of a list literal's inside (each checked by the grammar)."""
    return numbers.fields(text, offset)


def _arguments(code: str, start: int) -> list[tuple[int, int]]:
    """Spans of the top-level arguments of the call whose ``(`` is at ``start - 1``."""
    depth, begin, out = 0, start, []
    for i in range(start, len(code)):
        ch = code[i]
        if ch in "([":
            depth += 1
        elif ch in ")]":
            if depth == 0:
                out.append((begin, i))
                return out
            depth -= 1
        elif ch == "," and depth == 0:
            out.append((begin, i))
            begin = i + 1
    out.append((begin, len(code)))  # a call cut off by the line's end: its last argument
    return out


def _tcp(text: str, where: str) -> np.ndarray:
    fields = _numbers_in(text, 0)
    bad = numbers.first_problem(fields)
    if len(fields) != 6 or bad is not None:
        raise FilterError(
            f"{where}: set_tcp needs a pose of 6 numbers" + (f" ({bad})" if bad else "")
        )
    values = [float(t) for t, _, _ in fields]
    return _decode_pose(np.array([values]))[0]


@language("urscript", (".script",), "Universal Robots URScript (m, rad; set_tcp)")
class URScript(Language):
    comment = "#"

    def __init__(self, job: Job, program: Path) -> None:
        super().__init__(job, program)
        # First pass: the TCP each pose variable is moved to with.
        self.var_tool: dict[str, tuple] = {}
        tool, tool_line = None, 0
        plain = _PLAIN_MOVE.fullmatch
        for number, line in self._first_pass_lines(program):
            if plain(line) is not None:
                continue  # no TCP, no variable moved to
            code = _code_part(split_ending(line)[0])
            m = _TCP.search(code)
            if m:
                tool, tool_line = _tcp(m.group(1), f"{program}:{number}"), number
            for call in _MOVE.finditer(code):
                for a, b in _arguments(code, call.end())[: 2 if call.group(1) == "movec" else 1]:
                    name = code[a:b].strip()
                    if not re.fullmatch(r"[A-Za-z_]\w*", name):
                        continue
                    seen = self.var_tool.get(name)
                    if seen is not None and not _same(seen[0], tool):
                        raise FilterError(
                            f"{program}:{number}: {name} is moved to with the TCP set on line "
                            f"{tool_line or 'none'} here and the TCP of line {seen[1] or 'none'} "
                            f"before; one target cannot be corrected for two tools"
                        )
                    self.var_tool[name] = (tool, tool_line)

    @staticmethod
    def _first_pass_lines(program: Path) -> Iterator[tuple[int, str]]:
        """The lines that may set a TCP or move to a variable (runs of others skipped whole).

        A run of lines whose text holds no ``set_tcp``, no ``movec`` and no
        other move than of a literal has nothing the first pass looks for
        (its code, strings and comments blanked, holds less than its text).
        """
        for first, lines in read_chunks(program):
            text = "".join(lines)
            if "set_tcp" in text or "movec" in text or _MOVE_NOT_LITERAL.search(text):
                yield from enumerate(lines, start=first)

    def scan(self, path: Path) -> Iterator[Unit]:
        tool = None
        plain, file = _PLAIN_MOVE.fullmatch, str(path)
        for first, lines in read_chunks(path):
            for number, line in enumerate(lines, start=first):
                m = plain(line)
                if m is None:
                    unit, tool = self._unit(path, number, line, tool)
                    yield unit
                    continue
                target = Target(
                    file,
                    number,
                    m.group(1),
                    POSE if m.group(2) else JOINTS,
                    list(m.group(3, 4, 5, 6, 7, 8)),
                    [(0, a, b) for a, b in m.regs[3:9]],
                    tool,
                )  # fmt: skip
                yield Unit([line], [target])

    def _unit(self, path: Path, number: int, line: str, tool: Any) -> tuple[Unit, Any]:
        """One line read by the general path: its unit, and the TCP after it."""
        body, _ = split_ending(line)
        code = _code_part(body)
        unit = Unit([line])
        m = _TCP.search(code)
        if m:
            tool = _tcp(m.group(1), f"{path}:{number}")
        assign = _ASSIGN.match(code)
        cut = None if assign else _ASSIGN_START.match(code)
        if cut and cut.group(1) in self.var_tool:  # ``approach = p[0.1, 0.2`` cut off
            unit.targets.append(
                self._target(path, number, cut.group(1), [], cut.group(2) == "p", tool, _UNCLOSED)
            )
        if assign and assign.group(1) in self.var_tool:
            name, is_pose = assign.group(1), assign.group(2) == "p"
            nums = _numbers_in(assign.group(3), assign.start(3))
            unit.targets.append(
                self._target(path, number, name, nums, is_pose, self.var_tool[name][0])
            )
        for call in _MOVE.finditer(code):
            args = _arguments(code, call.end())
            for a, b in args[: 2 if call.group(1) == "movec" else 1]:
                arg = code[a:b]
                lit = re.fullmatch(r"\s*(p?)\s*\[([^\]]*)\]\s*", arg)
                if not lit:
                    opened = _OPENED.match(arg)
                    if opened:  # ``movel(p[0.1, 0.2`` cut off: a target that cannot be read
                        unit.targets.append(
                            self._target(
                                path,
                                number,
                                call.group(1),
                                [],
                                opened.group(1) == "p",
                                tool,
                                _UNCLOSED,
                            )  # fmt: skip
                        )
                    continue
                nums = _numbers_in(lit.group(2), a + lit.start(2))
                unit.targets.append(
                    self._target(path, number, call.group(1), nums, lit.group(1) == "p", tool)
                )
        return unit, tool

    def _target(self, path, number, label, nums, is_pose, tool, problem=None):
        layout = POSE if is_pose else JOINTS
        target = Target(
            file=str(path),
            line=number,
            label=label,
            layout=layout,
            tokens=[t for t, _, _ in nums],
            spans=[(0, s, e) for _, s, e in nums],
            tool=tool,
        )
        # A move's literal is its target: one that is not 6 numbers fails, never skipped.
        bad = numbers.first_problem(nums)
        if len(nums) != 6 or bad is not None:
            target.tokens, target.spans = ["0"] * 6, []
            target.problem = (
                problem
                or bad
                or f"{len(nums)} values, a {'pose' if is_pose else 'joint list'} has 6"
            )
        return target

    def code(self, q_deg: np.ndarray, bits: np.ndarray) -> np.ndarray:
        return np.asarray(bits)

    def code_bits(self, code: np.ndarray) -> np.ndarray:
        return np.asarray(code)

    def describe(self, code: tuple) -> str:
        return configuration.describe_bits(code)


def _same(a, b) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b, atol=1e-9))
