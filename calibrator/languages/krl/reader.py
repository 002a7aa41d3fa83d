"""KUKA KRL (KR C4, KSS 8.x): a ``.src`` with its ``.dat``.

Read from KUKA's KSS expert programming manual:

- Targets are ``E6POS``/``POS``/``FRAME`` (``X, Y, Z`` mm, ``A, B, C`` deg,
  ``Rz(A) Ry(B) Rx(C)``; ``S`` status and ``T`` turn on ``E6POS``/``POS``) or
  ``E6AXIS``/``AXIS`` (``A1..A6`` deg), declared (``DECL E6POS XP1={...}``,
  usually in the ``.dat``; or declared without a value and assigned
  ``NAME = {...}``) or written inline in ``PTP``/``LIN``/``CIRC``
  (and ``SPTP``/``SLIN``/``SCIRC``). External axes (``E1..E6``) are kept.
- The tool and base a target is meant in are those active where it is moved
  to: ``$TOOL = TOOL_DATA[n]``, ``$BASE = BASE_DATA[n]``, ``BAS(#TOOL, n)``,
  ``BAS(#BASE, n)`` or ``FDAT_ACT = FPx`` (the ``FDAT``'s ``TOOL_NO``,
  ``BASE_NO``), read in a first pass over the ``.src``; ``$TOOL = $NULLFRAME``
  and ``$BASE = $NULLFRAME`` are number 0. ``TOOL_DATA[n]`` and
  ``BASE_DATA[n]`` come from the controller's ``$config.dat`` (``--config-dat``)
  or ``--frames``; number 0 is the flange (KUKA's ``$FLANGE``, the
  description's controller flange) / the robot base (``$ROBROOT``, its
  controller base; ``$WORLD`` is taken to be ``$ROBROOT``).
- Status ``S`` (bit 0: wrist centre behind axis 1, "overhead area"; bit 1:
  elbow up; bit 2: ``A5`` negative) and turn ``T`` (bit i: axis i+1 negative),
  as :mod:`calibrator.languages.configuration` reads them. Only those bits are
  compared; a target without ``S``/``T`` (or a ``FRAME``) takes the
  configuration of the target before it.

A declared target used under two different tool/base pairs cannot be
corrected for both and is refused with both lines. A partial aggregate
(``LIN {X 100}``) changes some coordinates only: it cannot be corrected and
fails. Everything after ``;`` is a comment.
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
    numbered_frame,
    read_lines,
    split_ending,
    target_tool,
)
from calibrator.model import frames, rotations

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_COMPONENT = re.compile(r"([A-Za-z$]\w*)\s*(.*)$", re.DOTALL)
_DECL = re.compile(
    r"^\s*(?:DECL\s+)?(?:GLOBAL\s+)?(E6POS|POS|FRAME|E6AXIS|AXIS)\s+([A-Za-z_$]\w*)\s*=\s*\{",
    re.IGNORECASE,
)
_ASSIGN = re.compile(r"^\s*([A-Za-z_]\w*)\s*=\s*\{")
_MOTION = re.compile(r"^\s*(S?PTP|S?LIN|S?CIRC)\b\s*(.*)$", re.IGNORECASE)
_TOOL_SET = re.compile(r"\$TOOL\s*=\s*TOOL_DATA\s*\[\s*(\d+)\s*\]", re.IGNORECASE)
_BASE_SET = re.compile(r"\$BASE\s*=\s*BASE_DATA\s*\[\s*(\d+)\s*\]", re.IGNORECASE)
#: ``$TOOL = $NULLFRAME`` (the flange) and ``$BASE = $NULLFRAME`` ($ROBROOT): number 0.
_NULL_SET = re.compile(r"\$(TOOL|BASE)\s*=\s*\$NULLFRAME\b", re.IGNORECASE)
_BAS = re.compile(r"\bBAS\s*\(\s*#(TOOL|BASE)\s*,\s*(\d+)\s*\)", re.IGNORECASE)
_FDAT_ACT = re.compile(r"\bFDAT_ACT\s*=\s*([A-Za-z_]\w*)", re.IGNORECASE)
_FDAT = re.compile(r"^\s*DECL\s+(?:GLOBAL\s+)?FDAT\s+([A-Za-z_]\w*)\s*=\s*\{(.*)\}", re.IGNORECASE)
_FRAME_WORDS = re.compile(r"\$TOOL|\$BASE|BAS\s*\(|FDAT_ACT", re.IGNORECASE)
_CONFIG = re.compile(
    r"^\s*(TOOL_DATA|BASE_DATA)\s*\[\s*(\d+)\s*\]\s*=\s*\{([^}]*)\}", re.IGNORECASE
)

POSE_FIELDS = ("X", "Y", "Z", "A", "B", "C")
AXIS_FIELDS = ("A1", "A2", "A3", "A4", "A5", "A6")


def _decode_pose(v):
    return frames.transform(rotations.zyx_to_matrix(v[:, 3:]), v[:, :3])


def _encode_pose(pose, old):
    return np.concatenate(
        [pose[:, :3, 3], rotations.matrix_to_zyx(pose[:, :3, :3], old[:, 3:])], axis=1
    )


POSE = Layout("pose", ("mm",) * 3 + ("deg",) * 3, _decode_pose, _encode_pose)
JOINTS = Layout("joints", ("deg",) * 6, lambda v: np.radians(v), lambda q, old: np.degrees(q))


#: KRL's strings ("...") and ``;`` comments; ``'B010'`` literals are numbers, not strings.
_LEXER = Lexer(quotes='"', comment=";")


def _code(text: str) -> str:
    """A KRL line's code: strings and the comment blanked, every position kept."""
    return _LEXER.code(text)


_WHOLE = re.compile(r"[+-]?\d{1,18}|'[Bb][01]{1,64}'|'[Hh][0-9A-Fa-f]{1,16}'")


def _int(text: str) -> int:
    t = text.strip("'")
    if t[:1] in "Bb":
        return int(t[1:], 2)
    if t[:1] in "Hh":
        return int(t[1:], 16)
    return int(float(t))


def _whole(value: str, where: str, what: str) -> int:
    """A whole-number field (``TOOL_NO 3``, ``S 'B010'``) or one line naming it."""
    if not _WHOLE.fullmatch(value.strip()):
        raise FilterError(f"{where}: {what} {value.strip()[:40]!r} is not a whole number")
    return _int(value.strip())


#: The usual full E6POS/POS aggregate, in the order KUKA's editors write it.
_FULL_POSE = re.compile(
    (
        r"\{\s*X\s+(?P<X>NUM)\s*,\s*Y\s+(?P<Y>NUM)\s*,\s*Z\s+(?P<Z>NUM)\s*,\s*A\s+(?P<A>NUM)"
        r"\s*,\s*B\s+(?P<B>NUM)\s*,\s*C\s+(?P<C>NUM)\s*(?:,\s*S\s+(?P<S>NUM|'[Bb][01]+')\s*"
        r",\s*T\s+(?P<T>NUM|'[Bb][01]+'))?\s*[,}]"
    ).replace("NUM", _NUM)
)


def _fields(body: str, start: int) -> dict:
    """Components of an aggregate ``{...}`` starting at ``start``: name -> (text, start, end)."""
    m = _FULL_POSE.match(body, start)
    if m and m.group(0).endswith("}"):
        return {k: (v, m.start(k), m.end(k)) for k, v in m.groupdict().items() if v is not None}
    end = body.find("}", start)
    if end < 0:
        return {}
    # Each component is ``NAME value``; the value is everything up to the next
    # comma, so a malformed number is seen whole (``X 1.2.3``, ``X nan``, ``X ,``).
    out: dict[str, tuple[str, int, int]] = {}
    for item, at, _ in numbers.fields(body[start + 1 : end], start + 1):
        m = _COMPONENT.match(item)
        if m:
            out.setdefault(m.group(1).upper(), (m.group(2), at + m.start(2), at + m.end(2)))
    return out


def read_config_dat(path: Path | None) -> dict:
    """``{("tool", n): (4, 4), ("base", n): (4, 4)}`` from a controller's ``$config.dat``."""
    out: dict = {}
    if path is None:
        return out
    for number, line in read_lines(path):
        m = _CONFIG.match(_code(line))
        if not m:
            continue
        f = _fields("{" + m.group(3) + "}", 0)
        if not all(k in f for k in POSE_FIELDS):
            raise FilterError(
                f"{path}:{number}: {m.group(1)}[{m.group(2)}] lacks one of X Y Z A B C"
            )
        bad = numbers.first_problem([f[k][0] for k in POSE_FIELDS])
        if bad is not None:
            raise FilterError(f"{path}:{number}: {m.group(1)}[{m.group(2)}]: {bad}")
        v = np.array([[float(f[k][0]) for k in POSE_FIELDS]])
        kind = "tool" if m.group(1).upper() == "TOOL_DATA" else "base"
        out[(kind, int(m.group(2)))] = _decode_pose(v)[0]
    return out


def _sibling_dat(src: Path) -> Path | None:
    for cand in src.parent.iterdir() if src.parent.is_dir() else []:
        if cand.stem.lower() == src.stem.lower() and cand.suffix.lower() == ".dat":
            return cand
    return None


@language("krl", (".src",), "KUKA KRL .src with its .dat (mm, deg; A-B-C, S/T)")
class KRL(Language):
    comment = ";"

    def __init__(self, job: Job, program: Path) -> None:
        super().__init__(job, program)
        self.dat = _sibling_dat(self.program)
        self.config = read_config_dat(job.config_dat)
        self._config_decl: dict[str, str] = {}
        if job.config_dat is not None:
            for _, line in read_lines(job.config_dat):
                d = _DECL.match(_code(line))
                if d:
                    self._config_decl[d.group(2).upper()] = d.group(1).upper()
        fdat: dict = {}
        # Every position declared (or assigned) in the .dat and the .src: KRL
        # ignores case, so ``XP1`` and ``xp1`` are one name, declared twice.
        declared: dict[str, tuple] = {}
        if self.dat is not None:
            for number, line in read_lines(self.dat):
                _declare(_code(line), self.dat, number, fdat, declared, in_src=False)
        # One pass over the .src: its declarations, and the tool and base of
        # each named target's uses.
        self.uses: dict = {}
        first_use: dict[str, tuple] = {}
        state: list = [None, None]
        for number, line in read_lines(self.program):
            code = _code(line)
            _declare(code, self.program, number, fdat, declared, in_src=True)
            self._update(code, state, fdat)
            m = _MOTION.match(code)
            if not m:
                continue
            # The targets of a move come before its options (``WITH $VEL = ...``).
            moved = re.split(r"\bWITH\b", m.group(2), maxsplit=1, flags=re.IGNORECASE)[0]
            for name in re.findall(r"(?<![\w${])([A-Za-z_]\w*)", _strip_aggregates(moved)):
                if name.upper() in {"C_PTP", "C_DIS", "C_VEL", "C_ORI", "C_SPL", "CA"}:
                    continue
                key = name.upper()
                first_use.setdefault(key, (name, number))
                seen = self.uses.get(key)
                now = (state[0], state[1], number)
                if seen is not None and seen[:2] != now[:2]:
                    raise FilterError(
                        f"{self.program}:{number}: {name} is moved to with tool {now[0]} and base "
                        f"{now[1]} here and tool {seen[0]} and base {seen[1]} on line {seen[2]}; "
                        f"one target cannot be corrected for two frames"
                    )
                self.uses[key] = now
        # A target moved to but declared nowhere the filter reads would be left
        # uncorrected while the rest says "corrected": refused, first use first.
        for key, (name, number) in first_use.items():
            if key not in declared and not self._declared_elsewhere(name):
                where = "neither in the .src nor in its .dat"
                if self.dat is None:
                    where = f"in no .dat (there is no {self.program.stem}.dat beside it)"
                raise FilterError(
                    f"{self.program}:{number}: {name} is moved to but declared {where}; "
                    "its target cannot be corrected"
                )
        self.fdat = fdat

        self._frames: dict = {}  # (kind, number) -> (transform, problem), looked up once

    def _declared_elsewhere(self, name: str) -> bool:
        """``name`` is a joint position of the controller's ``$config.dat`` (kept as taught).

        Such a target (``XHOME``) is not in the files the filter rewrites: a
        joint position there stays as taught, which is what ``--joint-targets
        keep`` does anyway; a Cartesian one would go uncorrected, so it is not
        accepted.
        """
        if self.job.correct_joints:
            return False
        return self._config_decl.get(name.upper()) in ("E6AXIS", "AXIS")

    @staticmethod
    def _update(code: str, state: list, fdat: dict) -> None:
        if not _FRAME_WORDS.search(code):
            return  # most lines set no frame
        for m in _TOOL_SET.finditer(code):
            state[0] = int(m.group(1))
        for m in _BASE_SET.finditer(code):
            state[1] = int(m.group(1))
        for m in _NULL_SET.finditer(code):
            state[0 if m.group(1).upper() == "TOOL" else 1] = 0
        for m in _BAS.finditer(code):
            state[0 if m.group(1).upper() == "TOOL" else 1] = int(m.group(2))
        for m in _FDAT_ACT.finditer(code):
            tool, base = fdat.get(m.group(1).upper(), (None, None))
            state[0] = tool if tool is not None else state[0]
            state[1] = base if base is not None else state[1]

    def files(self, output: Path) -> list[tuple[Path, Path]]:
        pairs = []
        if self.dat is not None:
            pairs.append((self.dat, Path(output).with_suffix(".dat")))
        pairs.append((self.program, Path(output)))
        return pairs

    def _frame(self, kind: str, number: int | None, where: str):
        """The (4, 4) of TOOL_DATA/BASE_DATA[number]; (None, problem) when unknown."""
        key = (kind, number)
        if key not in self._frames:
            self._frames[key] = self._look_up(kind, number)
        return self._frames[key]

    def _look_up(self, kind: str, number: int | None):
        if number is None:
            return (
                None,
                f"no {kind} is set before its use ({'$TOOL' if kind == 'tool' else '$BASE'})",
            )
        if (kind, number) in self.config:  # $config.dat wins over --frames
            return self.config[(kind, number)], None
        frame = numbered_frame(self.job, kind, number)
        if frame is not None:
            return frame, None
        data = "TOOL_DATA" if kind == "tool" else "BASE_DATA"
        return None, f"{data}[{number}] is defined neither in --config-dat nor in --frames"

    def scan(self, path: Path) -> Iterator[Unit]:
        in_src = path == self.program
        state: list = [None, None]
        for number, line in read_lines(path):
            body, _ = split_ending(line)
            code = _code(body)
            unit = Unit([line])
            if in_src:
                self._update(code, state, self.fdat)
            decl = _DECL.match(code)
            if decl:
                use = self.uses.get(decl.group(2).upper())
                if use is not None:  # declared and moved to: a target
                    unit.targets.append(
                        self._target(
                            path,
                            number,
                            decl.group(2),
                            decl.group(1).upper(),
                            code,
                            decl.end() - 1,
                            use[:2],
                        )
                    )
            elif (assign := _ASSIGN.match(code)) and assign.group(1).upper() in self.uses:
                # ``HOMEPOS = {A1 0, ...}``: a target declared without a value, assigned here.
                name, brace = assign.group(1), assign.end() - 1
                axis = re.match(r"\{\s*A[1-6]\s", code[brace:], re.IGNORECASE)
                use = self.uses[name.upper()]
                unit.targets.append(
                    self._target(
                        path, number, name, "AXIS" if axis else "E6POS", code, brace, use[:2]
                    )
                )
            elif in_src:
                m = _MOTION.match(code)
                if m:
                    for pos in _top_braces(code, m.start(2)):
                        kind = (
                            "AXIS"
                            if re.match(r"\{\s*A[1-6]\s", code[pos:], re.IGNORECASE)
                            else "E6POS"
                        )
                        unit.targets.append(
                            self._target(
                                path, number, m.group(1).upper(), kind, code, pos, tuple(state)
                            )
                        )
            yield unit

    def _target(self, path, number, label, kind, code, brace, frames_used):
        f = _fields(code, brace)
        joints = kind in ("E6AXIS", "AXIS")
        names = AXIS_FIELDS if joints else POSE_FIELDS
        target = Target(
            file=str(path),
            line=number,
            label=label,
            layout=JOINTS if joints else POSE,
            tokens=[],
            spans=[],
        )
        if not all(k in f for k in names):
            target.tokens, target.problem = ["0"] * 6, "a partial aggregate cannot be corrected"
            return target
        bad = numbers.first_problem([f[k][0] for k in names])
        status = [f[k][0] for k in ("S", "T") if k in f and not joints]
        if bad is None and any(not _WHOLE.fullmatch(v) for v in status):
            bad = "S or T is not a whole number"
        if bad is not None:
            target.tokens, target.problem = ["0"] * 6, bad
            return target
        target.tokens = [f[k][0] for k in names]
        target.spans = [(0, f[k][1], f[k][2]) for k in names]
        where = f"{path}:{number}"
        tool, p1 = target_tool(self.job, joints, self._frame("tool", frames_used[0], where))
        base, p2 = (None, None) if joints else self._frame("base", frames_used[1], where)
        target.tool, target.base, target.problem = tool, base, p1 or p2
        if not joints and "S" in f and "T" in f:
            target.code = (_int(f["S"][0]) & 7, _int(f["T"][0]) & 63)
        return target

    def code(self, q_deg: np.ndarray, bits: np.ndarray) -> np.ndarray:
        bits = np.asarray(bits)
        s = bits[:, 0] + 2 * (1 - bits[:, 1]) + 4 * bits[:, 2]
        t = np.sum(configuration.negative(q_deg) << np.arange(6), axis=1)
        return np.column_stack([s, t])

    def code_bits(self, code: np.ndarray) -> np.ndarray:
        s = np.asarray(code)[:, 0]
        return np.column_stack([s & 1, 1 - ((s >> 1) & 1), (s >> 2) & 1])

    def describe(self, code: tuple) -> str:
        return f"S {code[0]} T {code[1]}"


def _declare(code: str, path: Path, number: int, fdat: dict, declared: dict, in_src: bool) -> None:
    """Note an ``FDAT`` (its tool and base numbers) or a position declared on this line.

    Refuses a position declared twice (KRL ignores case: ``XP1`` and ``xp1``
    are one name). In the ``.src``, ``NAME = {...}`` also gives a value to a
    position declared without one.
    """
    m = _FDAT.match(code)
    if m:
        where = f"{path}:{number}"
        f = _fields("{" + m.group(2) + "}", 0)
        tool = _whole(f["TOOL_NO"][0], where, "TOOL_NO") if "TOOL_NO" in f else None
        base = _whole(f["BASE_NO"][0], where, "BASE_NO") if "BASE_NO" in f else None
        fdat[m.group(1).upper()] = (tool, base)
        return
    decl = _DECL.match(code)
    if decl:
        key = decl.group(2).upper()
        if key in declared:
            first = declared[key]
            raise FilterError(
                f"{path}:{number}: {decl.group(2)} is declared again (KRL ignores case; "
                f"first at {first[0]}:{first[1]}); which one is moved to is unclear"
            )
        declared[key] = (path, number)
    elif in_src and (assign := _ASSIGN.match(code)):
        declared.setdefault(assign.group(1).upper(), (path, number))


def _strip_aggregates(text: str) -> str:
    return re.sub(r"\{[^}]*\}", " ", text)


def _top_braces(code: str, start: int) -> list[int]:
    if code.count("{") == 1:
        at = code.find("{", start)
        return [at] if at >= 0 else []
    if code.count("{") == code.count("}") == len(re.findall(r"\{[^{}]*\}", code)):
        return [m.start() for m in re.finditer(r"\{", code[start:])] and [
            start + m.start() for m in re.finditer(r"\{", code[start:])
        ]  # no nesting: every brace opens a target
    out, depth = [], 0
    for i in range(start, len(code)):
        if code[i] == "{":
            if depth == 0:
                out.append(i)
            depth += 1
        elif code[i] == "}":
            depth -= 1
    return out
