"""Small grammar checkers of the four controller languages, from their public references.

Each checker parses a whole program, refuses any line that is not a
statement of the (sub)language the writers may use, and returns the joint
targets of the motion statements in order, in rad, with the names of
targets referenced by name (home). Written independently of the writers.

References: URScript manual (movej, sleep, set_standard_digital_out), KUKA
KSS 8 system programming (DEF/END, DECL E6AXIS, PTP, $VEL_AXIS, $ACC_AXIS,
WAIT SEC, PULSE), ABB RAPID instructions (MODULE, CONST jointtarget,
MoveAbsJ with \\T, WaitTime \\InPos, PulseDO \\PLength), Fanuc LS ASCII
program format (/PROG, /ATTR, /MN numbered lines, J P[i] n% FINE, WAIT
(sec), DO[i]=PULSE, /POS joint representation, /END).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

NUM = r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?"
IDENT = r"[A-Za-z][A-Za-z0-9_]*"


class GrammarError(AssertionError):
    """A line that is no statement of the language."""


@dataclass
class Parsed:
    """Motion statements in order: ``("literal", q_rad)`` or ``("named", name)``."""

    moves: list = field(default_factory=list)
    named: dict = field(default_factory=dict)  # name -> q_rad
    waits: list = field(default_factory=list)  # s
    pulses: int = 0
    speeds: dict = field(default_factory=dict)
    move_times: list = field(default_factory=list)  # RAPID \T per move, None if untimed
    order: str = ""  # "m" per motion statement, "w" per wait, in program order

    def targets(self) -> list:
        """Every motion target as joints (rad), named ones resolved."""
        return [q if kind == "literal" else self.named[q] for kind, q in self.moves]

    def literal(self) -> list:
        return [q for kind, q in self.moves if kind == "literal"]

    def move(self, target, where: str) -> None:
        """A motion statement: to joints written out (rad), or to a target's name.

        A name must have been given its joints before (``where`` names the line).
        """
        if isinstance(target, str):
            if target not in self.named:
                raise GrammarError(f"{where}: {target} used before it has a value")
            self.moves.append(("named", target))
        else:
            self.moves.append(("literal", target))
        self.order += "m"

    def wait(self, seconds: str) -> None:
        """A wait statement of ``seconds`` (as written)."""
        self.waits.append(float(seconds))
        self.order += "w"


def _nums(text: str, count: int, scale: float = 1.0) -> list:
    values = [float(v) * scale for v in re.findall(NUM, text)]
    if len(values) != count:
        raise GrammarError(f"expected {count} numbers in {text!r}")
    return values


def _wait_or_pulse(out: Parsed, statement: str, wait: str, pulse: str) -> bool:
    """Take a wait (regex ``wait``, group 1 its seconds) or a pulse; False if it is neither."""
    if m := re.fullmatch(wait, statement):
        out.wait(m.group(1))
    elif re.fullmatch(pulse, statement):
        out.pulses += 1
    else:
        return False
    return True


def _fail(n: int, line: str, lang: str):
    raise GrammarError(f"{lang} line {n}: not a statement: {line!r}")


# ---------------------------------------------------------------- URScript

UR_LIST = rf"\[\s*{NUM}(?:\s*,\s*{NUM}){{5}}\s*\]"


def parse_urscript(text: str) -> Parsed:
    out = Parsed()
    lines = text.splitlines()
    body = False
    name = None
    for n, line in enumerate(lines, 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if m := re.fullmatch(rf"def ({IDENT})\(\):", line):
            name, body = m.group(1), True
            continue
        if line == "end":
            body = False
            continue
        if not body:
            if name and line == f"{name}()":
                continue
            _fail(n, line, "URScript")
        if not line.startswith("  "):
            _fail(n, line, "URScript (indentation)")
        if m := re.fullmatch(rf"({IDENT}) = ({UR_LIST})", s):
            out.named[m.group(1)] = _nums(m.group(2), 6)
        elif m := re.fullmatch(rf"movej\(({UR_LIST}|{IDENT}), a=({NUM}), v=({NUM})\)", s):
            target = m.group(1)
            out.move(_nums(target, 6) if target.startswith("[") else target, f"URScript line {n}")
            out.speeds.setdefault("v", set()).add(float(m.group(3)))
            out.speeds.setdefault("a", set()).add(float(m.group(2)))
        elif m := re.fullmatch(rf"sleep\(({NUM})\)", s):
            out.wait(m.group(1))
        elif re.fullmatch(r"set_standard_digital_out\(\d, (True|False)\)", s):
            out.pulses += s.endswith("True)")
        else:
            _fail(n, line, "URScript")
    if body or name is None:
        raise GrammarError("URScript: def without end")
    return out


# ---------------------------------------------------------------- KRL

KRL_AXIS = rf"\{{A1 ({NUM}), A2 ({NUM}), A3 ({NUM}), A4 ({NUM}), A5 ({NUM}), A6 ({NUM})\}}"


def parse_krl(text: str) -> Parsed:
    out = Parsed()
    lines = [ln for ln in text.splitlines() if ln.strip()]
    deg = math.pi / 180.0
    if not re.fullmatch(rf"DEF ({IDENT})\(\)", lines[0]) or lines[-1] != "END":
        raise GrammarError("KRL: a program is DEF NAME() ... END")
    declared: set = set()
    statements_started = False
    for n, line in enumerate(lines[1:-1], 2):
        if line.startswith(";"):
            continue
        if m := re.fullmatch(rf"DECL E6AXIS ({IDENT})", line):
            if statements_started:
                raise GrammarError(f"KRL line {n}: declaration after a statement")
            declared.add(m.group(1))
            continue
        statements_started = True
        if m := re.fullmatch(rf"({IDENT}) = {KRL_AXIS}", line):
            if m.group(1) not in declared:
                raise GrammarError(f"KRL line {n}: {m.group(1)} not declared")
            out.named[m.group(1)] = [float(v) * deg for v in m.groups()[1:]]
        elif m := re.fullmatch(rf"\$VEL_AXIS\[([1-6])\] = ({NUM})", line):
            out.speeds[int(m.group(1))] = float(m.group(2))
        elif m := re.fullmatch(rf"\$ACC_AXIS\[([1-6])\] = ({NUM})", line):
            if not 0 < float(m.group(2)) <= 100:
                raise GrammarError(f"KRL line {n}: percent out of range")
        elif re.fullmatch(r"\$(TOOL|BASE) = \$NULLFRAME", line):
            continue  # the frames the program assumes (flange, robot base)
        elif m := re.fullmatch(rf"PTP {KRL_AXIS}", line):
            out.move([float(v) * deg for v in m.groups()], f"KRL line {n}")
        elif m := re.fullmatch(rf"PTP ({IDENT})", line):
            out.move(m.group(1), f"KRL line {n}")
        elif not _wait_or_pulse(
            out, line, rf"WAIT SEC ({NUM})", rf"PULSE\(\$OUT\[\d+\], TRUE, ({NUM})\)"
        ):
            _fail(n, line, "KRL")
    return out


# ---------------------------------------------------------------- RAPID

RAPID_JT = rf"\[\[({NUM}(?:,{NUM}){{5}})\],\[9E9(?:,9E9){{5}}\]\]"


def parse_rapid(text: str) -> Parsed:
    out = Parsed()
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    deg = math.pi / 180.0
    if not re.fullmatch(rf"MODULE {IDENT}", lines[0]) or lines[-1] != "ENDMODULE":
        raise GrammarError("RAPID: a module is MODULE NAME ... ENDMODULE")
    in_proc = False
    for n, line in enumerate(lines[1:-1], 2):
        if line.startswith("!"):
            continue
        if line == "PROC main()":
            in_proc = True
            continue
        if line == "ENDPROC":
            in_proc = False
            continue
        if not in_proc:
            if m := re.fullmatch(rf"CONST jointtarget ({IDENT}) := {RAPID_JT};", line):
                out.named[m.group(1)] = _nums(m.group(2), 6, deg)
                continue
            _fail(n, line, "RAPID (data)")
        if m := re.fullmatch(
            rf"MoveAbsJ ({RAPID_JT}|{IDENT}), v\d+(?: \\T:=({NUM}))?, fine, tool0;", line
        ):
            target = m.group(1)
            literal = target.startswith("[")
            out.move(_nums(m.group(2), 6, deg) if literal else target, f"RAPID line {n}")
            out.move_times.append(None if m.group(3) is None else float(m.group(3)))
        elif not _wait_or_pulse(
            out, line, rf"WaitTime \\InPos, ({NUM});", rf"PulseDO \\PLength:=({NUM}), {IDENT};"
        ):
            _fail(n, line, "RAPID")
    return out


# ---------------------------------------------------------------- Fanuc LS


def parse_fanuc(text: str) -> Parsed:
    out = Parsed()
    deg = math.pi / 180.0
    sections = re.split(r"^(/PROG|/ATTR|/MN|/POS|/END)\b", text, flags=re.M)
    order = [s for s in sections if s in ("/PROG", "/ATTR", "/MN", "/POS", "/END")]
    if order != ["/PROG", "/ATTR", "/MN", "/POS", "/END"]:
        raise GrammarError(f"Fanuc LS sections out of order: {order}")
    parts = dict(zip(sections[1::2], sections[2::2], strict=True))
    if not re.fullmatch(rf"\s+{IDENT}\s*", parts["/PROG"]):
        raise GrammarError("Fanuc LS: /PROG needs a name")
    attrs = {}
    for line in parts["/ATTR"].strip().splitlines():
        if not (m := re.fullmatch(r"(\w+)\s*= (.*);", line.strip())):
            raise GrammarError(f"Fanuc LS /ATTR: {line!r}")
        attrs[m.group(1)] = m.group(2)
    points = {}
    for m in re.finditer(
        rf"P\[(\d+)(?::\"?[^\]\"]*\"?)?\]\{{\s*GP1:\s*UF : \d+, UT : \d+,\s*"
        rf"J1= ({NUM}) deg,\s*J2= ({NUM}) deg,\s*J3= ({NUM}) deg,\s*"
        rf"J4= ({NUM}) deg,\s*J5= ({NUM}) deg,\s*J6= ({NUM}) deg\s*\}};",
        parts["/POS"],
    ):
        points[int(m.group(1))] = [float(v) * deg for v in m.groups()[1:]]
    leftover = re.sub(r"P\[[^\]]*\]\{[^}]*\};", "", parts["/POS"]).strip()
    if leftover or not points:
        raise GrammarError(f"Fanuc LS /POS: unparsed {leftover[:60]!r}")
    mn = [ln for ln in parts["/MN"].splitlines() if ln.strip()]
    if int(attrs.get("LINE_COUNT", -1)) != len(mn):
        raise GrammarError("Fanuc LS: LINE_COUNT differs from the /MN lines")
    for expect, line in enumerate(mn, 1):
        if not (m := re.fullmatch(r"\s*(\d+):\s+(.*) ;", line)) or int(m.group(1)) != expect:
            raise GrammarError(f"Fanuc LS /MN line {expect}: {line!r}")
        stmt = m.group(2)
        if mm := re.fullmatch(r"J P\[(\d+)(?::\w+)?\] (\d+)% FINE", stmt):
            index = int(mm.group(1))
            if index not in points:
                raise GrammarError(f"Fanuc LS: P[{index}] not in /POS")
            out.move(points[index], f"Fanuc LS /MN line {expect}")
            out.speeds.setdefault("percent", set()).add(int(mm.group(2)))
        elif re.fullmatch(r"(UFRAME_NUM|UTOOL_NUM)=0", stmt):
            continue  # World and the faceplate, the frames the positions are in
        elif not _wait_or_pulse(out, stmt, rf"WAIT ({NUM})\(sec\)", rf"DO\[\d+\]=PULSE,{NUM}sec"):
            raise GrammarError(f"Fanuc LS /MN line {expect}: not a statement: {stmt!r}")
    return out


PARSERS = {
    "urscript": parse_urscript,
    "krl": parse_krl,
    "rapid": parse_rapid,
    "fanuc-ls": parse_fanuc,
}
