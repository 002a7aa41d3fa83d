"""Fault scripts for the simulator: which reply goes wrong, and how.

A script is text, one fault per line, ``#`` starts a comment::

    MEAS@5   beam_break count=3   # 5th MEAS since start and the 2 after it
    MEAS+2   bad_crc              # 2nd MEAS after this fault was armed
    ID?@1    garble
    STAT?@2  drop
    MEAS@7   partial delay=0.5
    MEAS@8   delay delay=0.05
    *@20     hangup               # * = any command
    MEAS@9   not_initialised
    MEAS@10  unstable count=4
    MEAS@11  inaccurate
    MEAS@12  error code=10        # any ErrorCode, by number or name
    SAMPLE+50 beam_break count=20 # stream ticks count as SAMPLE
    SAMPLE+80 stall delay=1.0     # the stream falls silent for 1 s

The same line can be armed over the wire with ``SIM,FAULT,<line>``.
Every value is checked here (a bad one is a ``ValueError`` naming it), so a
fault line from the wire can never stop or stall the simulator: counts are
1..999999, delays are protocol decimals in 0..:data:`MAX_DELAY_S` seconds,
codes are :class:`~drivers.tracker.line.protocol.ErrorCode` names or numbers.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from drivers.tracker.line.protocol import ErrorCode, parse_number

KINDS = frozenset(
    {
        "beam_break",
        "garble",
        "bad_crc",
        "drop",
        "partial",
        "delay",
        "hangup",
        "not_initialised",
        "unstable",
        "inaccurate",
        "error",
        "stall",  # stream ticks only: silent for `delay` seconds, those ticks lost
    }
)

_TRIGGER = re.compile(r"(?P<cmd>[A-Z?*]+)(?P<op>[@+])(?P<n>[1-9][0-9]{0,8})", re.ASCII)
_COUNT = re.compile(r"[1-9][0-9]{0,5}", re.ASCII)
MAX_DELAY_S = 60.0  # a longer delay is no fault any client could wait for


@dataclass
class Fault:
    """One scripted fault.

    Attributes
    ----------
    command : str
        Command name it applies to (``"*"`` for any).
    nth : int
        Occurrence number that triggers it (absolute or relative, see ``relative``).
    kind : str
        One of :data:`KINDS`.
    relative : bool
        True: ``nth`` counts from the moment the fault was armed.
    count : int
        Number of consecutive commands affected (beam_break, unstable, inaccurate).
    delay_s : float
        Delay for ``partial`` and ``delay``.
    code : ErrorCode
        Code for ``error``.
    """

    command: str
    nth: int
    kind: str
    relative: bool = False
    count: int = 1
    delay_s: float = 0.5
    code: ErrorCode = ErrorCode.BUSY


def parse_fault(line: str) -> Fault:
    """Parse one fault line (see module docstring).

    Raises
    ------
    ValueError
        Naming the offending part.
    """
    parts = line.split("#", 1)[0].split()  # '#' never appears in triggers or options
    if len(parts) < 2:
        raise ValueError(f"fault needs '<CMD>@<n>|<CMD>+<n> <kind> [key=value]': {line!r}")
    m = _TRIGGER.fullmatch(parts[0])
    if not m:
        raise ValueError(f"bad trigger {parts[0]!r}; expected e.g. MEAS@5 or MEAS+1")
    kind = parts[1]
    if kind not in KINDS:
        raise ValueError(f"unknown fault kind {kind!r}; known: {sorted(KINDS)}")
    fault = Fault(m["cmd"], int(m["n"]), kind, relative=m["op"] == "+")
    for option in parts[2:]:
        key, _, value = option.partition("=")
        if key == "count":
            if not _COUNT.fullmatch(value):
                raise ValueError(f"count must be a whole number 1..999999: {line!r}")
            fault.count = int(value)
        elif key == "delay":
            fault.delay_s = _delay(value, line)
        elif key == "code":
            fault.code = _code(value, line)
        else:
            raise ValueError(f"unknown fault option {key!r} in {line!r}")
    return fault


def _delay(value: str, line: str) -> float:
    """Seconds in 0..MAX_DELAY_S, written as a protocol decimal (no inf, nan, exponent)."""
    delay = parse_number(value)  # ValueError for inf, nan, 1e3, ...
    if not 0.0 <= delay <= MAX_DELAY_S:
        raise ValueError(f"delay must be 0..{MAX_DELAY_S:g} s: {line!r}")
    return delay


def _code(value: str, line: str) -> ErrorCode:
    """An ErrorCode by number or name."""
    if value.isascii() and value.isdigit() and len(value) <= 3:
        try:
            return ErrorCode(int(value))
        except ValueError:
            pass
    elif value in ErrorCode.__members__:
        return ErrorCode[value]
    known = ", ".join(ErrorCode.__members__)
    raise ValueError(f"unknown error code {value!r} in {line!r}; known: {known}")


def parse_script(text: str) -> list[Fault]:
    """Parse a whole fault script (blank and comment lines ignored).

    Raises
    ------
    ValueError
        Naming the line number and the offending part.
    """
    faults = []
    for number, line in enumerate(text.splitlines(), start=1):
        if line.split("#", 1)[0].strip():
            try:
                faults.append(parse_fault(line))
            except ValueError as exc:
                raise ValueError(f"line {number}: {exc}") from None
    return faults


class FaultSchedule:
    """Armed faults, matched against the command counters of the simulator."""

    def __init__(self, faults: list[Fault] | None = None):
        self._pending: list[tuple[Fault, int]] = []  # (fault, absolute occurrence)
        self._counts: dict[str, int] = {}
        for fault in faults or []:
            self.arm(fault)

    def arm(self, fault: Fault) -> None:
        """Arm a fault; a relative trigger counts from the current occurrence count."""
        base = self._counts.get(fault.command, 0) if fault.relative else 0
        self._pending.append((fault, base + fault.nth))

    def next_command(self, name: str, count_any: bool = True) -> list[Fault]:
        """Count one received command and return the faults it triggers, in script order.

        ``count_any=False`` (stream ticks, ``SAMPLE``) leaves the ``*`` count
        alone: a ``*@n`` trigger counts commands only.
        """
        hits = []
        for key in (name, "*") if count_any else (name,):
            self._counts[key] = self._counts.get(key, 0) + 1
        for fault, at in list(self._pending):
            key = "*" if fault.command == "*" else name
            if fault.command == "*" and not count_any:
                continue
            if fault.command in (name, "*") and self._counts[key] == at:
                hits.append(fault)
                self._pending.remove((fault, at))
        return hits
