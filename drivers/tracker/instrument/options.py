"""Command-line pieces both simulated front-ends share: option types, the parent watch, the clock.

Each option type turns a bad value into one usage line naming what was
expected (argparse then exits 2).
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import time
from collections.abc import Callable
from typing import NoReturn

from drivers.tracker.instrument.instrument import ON_S
from drivers.tracker.line.protocol import parse_number


class OneLineParser(argparse.ArgumentParser):
    """argparse with its usage errors as one line (no usage block) and exit 2."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}\n")


def add_on_time(parser: argparse.ArgumentParser, help_text: str) -> None:
    """``--on-time S``: the tracker's time since power-on at start (default: warmed up)."""
    parser.add_argument("--on-time", type=on_time, default=ON_S, metavar="S", help=help_text)


def add_time_scale(parser: argparse.ArgumentParser, help_text: str) -> None:
    """``--time-scale X``: the tracker's clock runs X times faster than the wall clock."""
    parser.add_argument("--time-scale", type=time_scale, default=1.0, metavar="X", help=help_text)


def triple(text: str) -> list[float]:
    try:
        values = [parse_number(v.strip()) for v in text.split(",")]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    if len(values) not in (3, 6):
        raise argparse.ArgumentTypeError("expected x,y,z or x,y,z,rx,ry,rz")
    return values


def port(text: str) -> int:
    if not text.isascii() or not text.isdigit() or int(text) > 65535:
        raise argparse.ArgumentTypeError(f"port must be 0..65535, got {text!r}")
    return int(text)


def number_within(text: str, low: float, high: float, expected: str) -> float:
    """``text`` as a finite number in ``[low, high]``, else a usage error naming ``expected``."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and low <= value <= high):
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
    return value


def seconds(text: str) -> float:
    return number_within(text, 0.0, 3600.0, "seconds in 0..3600")


def air(text: str) -> tuple[float, float, float]:
    try:
        values = [parse_number(v.strip()) for v in text.split(",")]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    limits = ((-10.0, 50.0), (500.0, 1200.0), (0.0, 100.0))
    inside = len(values) == 3 and all(
        lo <= v <= hi for v, (lo, hi) in zip(values, limits, strict=True)
    )
    if not inside:
        raise argparse.ArgumentTypeError("expected T,P,H in -10..50 degC, 500..1200 hPa, 0..100 %")
    return values[0], values[1], values[2]


def on_time(text: str) -> float:
    return number_within(text, 0.0, 1e8, "seconds >= 0")


def time_scale(text: str) -> float:
    return number_within(text, 0.01, 100.0, "a time scale in 0.01..100")


def latency(text: str) -> float:
    return number_within(text, 0.0, 1.0, "a latency in 0..1 s")


def seed(text: str) -> int:
    if not text.isascii() or not text.isdigit():
        raise argparse.ArgumentTypeError(f"seed must be a whole number >= 0, got {text!r}")
    return int(text)


def exit_with_parent(parent: int) -> None:
    """SIGTERM ourselves once the parent is gone, so crashed test runs leave no simulators."""
    while os.getppid() == parent:
        time.sleep(0.5)
    os.kill(os.getpid(), signal.SIGTERM)


def scaled_clock(scale: float) -> Callable[[], float]:
    """The wall clock (monotonic, s) run ``scale`` times faster; itself at scale 1."""
    if scale == 1.0:
        return time.monotonic
    return lambda: scale * time.monotonic()
