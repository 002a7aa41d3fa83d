"""Replay a recorded exchange as the tracker side.

Each host frame received is matched against the next recorded host frame
(command and arguments; the sequence number may differ) and answered with
exactly the bytes the tracker sent after it in the recording, including
partial lines, events and garbled lines. Timing is not reproduced: the
bytes go out at once, so a recorded timeout replays as a timeout only
because its reply was missing from the recording too.
"""

from __future__ import annotations

import threading
from pathlib import Path

from drivers.tracker.errors import FrameError
from drivers.tracker.instrument import Output, Send
from drivers.tracker.line.protocol import (
    ErrorCode,
    decode_frame,
    encode_frame,
    error_body,
    parse_command,
    parse_reply,
)
from drivers.tracker.line.simulator.engine import bad_frame_reply
from drivers.tracker.recording import group_exchanges, read_log


class ReplaySimulator:
    """Tracker side that answers from a recording (same ``handle_line`` as the live simulator).

    Parameters
    ----------
    path : str or Path
        A log written by :class:`drivers.tracker.recording.Recorder`.
    """

    def __init__(self, path: str | Path):
        self._exchanges = group_exchanges(read_log(path))
        self._next = 0
        self._lock = threading.Lock()

    @property
    def remaining(self) -> int:
        """Recorded host frames not yet replayed."""
        return len(self._exchanges) - self._next

    def handle_line(self, line: bytes) -> list[Output]:
        with self._lock:
            try:
                cmd = parse_command(decode_frame(line))
            except FrameError as exc:
                return [bad_frame_reply(line, exc)]
            expected = None
            while self._next < len(self._exchanges):
                tx, chunks = self._exchanges[self._next]
                expected = parse_command(decode_frame(tx))
                # A recorded COND? the host does not ask again (conditions are no reading):
                # skipped, so recordings with and without the query both replay.
                if expected.name == "COND?" and cmd.name != "COND?":
                    self._next += 1
                    expected = None
                    continue
                break
            if expected is None or (expected.name, expected.args) != (cmd.name, cmd.args):
                if cmd.name == "COND?":  # a recording from before the query: not known then
                    body = error_body(cmd.seq, ErrorCode.UNKNOWN_COMMAND, cmd.name)
                    return [Send(encode_frame(body))]
                if cmd.name == "SIM":  # target updates from an unrecorded control link
                    return [Send(encode_frame(f"OK,{cmd.seq}"))]
                want = "end of recording" if expected is None else f"expected {expected.name}"
                body = error_body(cmd.seq, ErrorCode.REPLAY_MISMATCH, want)
                return [Send(encode_frame(body))]
            self._next += 1
            if expected.seq == cmd.seq:
                return [Send(chunk) for chunk in chunks]
            return [Send(_reseq(b"".join(chunks), expected.seq, cmd.seq))]


def _reseq(data: bytes, old: int, new: int) -> bytes:
    """Re-frame complete reply lines for ``old`` with sequence number ``new``; keep the rest."""
    out = []
    lines = data.split(b"\r\n")
    for i, line in enumerate(lines):
        last = i == len(lines) - 1
        if not last:
            try:
                reply = parse_reply(decode_frame(line))
                if reply.seq == old:
                    line = encode_frame(",".join([reply.kind.value, str(new), *reply.fields]))[:-2]
            except FrameError:
                pass  # garbled lines replay as recorded
        out.append(line)
    return b"\r\n".join(out)
