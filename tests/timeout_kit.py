"""Reading a child's pipe with a deadline: a test that hangs is a failing test.

A child that never writes its line (stuck in start-up, or dead with a
grandchild still holding the pipe) would block ``readline`` for ever. The
line is read by a helper thread instead; past the deadline the test fails
naming what it waited for, and its clean-up (killing the child) ends the
read.
"""

from __future__ import annotations

import threading
from typing import IO, AnyStr

#: Seconds a child gets to write a line it owes (start-up on a loaded two-core machine).
LINE_S = 60.0


def readline(stream: IO[AnyStr], timeout_s: float = LINE_S, what: str = "a line") -> AnyStr:
    """``stream.readline()``, failing the test after ``timeout_s`` seconds without a line."""
    got: list = []
    reader = threading.Thread(target=lambda: got.append(stream.readline()), daemon=True)
    reader.start()
    reader.join(timeout_s)
    if reader.is_alive() or not got:
        raise AssertionError(f"no {what} from the child within {timeout_s:g} s")
    return got[0]


def within(call, timeout_s: float = LINE_S, what: str = "the call"):
    """``call()``, failing the test after ``timeout_s`` seconds without its return.

    For calls with no deadline of their own (a helper process's pipe read):
    the call runs in a helper thread, which a failed test leaves blocked
    until its process is ended.
    """
    done: list = []
    raised: list = []

    def run() -> None:
        try:
            done.append(call())
        except BaseException as exc:  # handed back to the test below
            raised.append(exc)

    worker = threading.Thread(target=run, daemon=True)
    worker.start()
    worker.join(timeout_s)
    if worker.is_alive():
        raise AssertionError(f"{what} did not return within {timeout_s:g} s")
    if raised:
        raise raised[0]
    return done[0]
