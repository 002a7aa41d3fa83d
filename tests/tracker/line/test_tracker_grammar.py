"""The protocol's number and frame grammar, enforced (issue 8, item 4), with property tests.

The grammar is the one in docs/tracker-protocol.md ("Numbers"): a decimal is
an optional ``-``, 1 to 9 digits without a leading zero (except ``0``
itself), and optionally ``.`` and 1 to 9 digits; a CRC is four upper-case
hex digits. Anything else in a reply is a :class:`FrameError`, never a
value.
"""

from __future__ import annotations

import math
import string

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from tracker_kit import ScriptedTransport, host

from drivers.errors import DriverError
from drivers.tracker import FrameError
from drivers.tracker.line.link import Link
from drivers.tracker.line.protocol import (
    MAX_FRAME,
    ReadingStatus,
    crc16,
    decode_frame,
    encode_frame,
    format_number,
    ok_body,
    parse_command,
    parse_number,
    parse_reading,
    parse_reply,
    reading_fields,
)

GOOD = "OK,4,P3,2500.0051,399.9896,-300.0042,ACC,1534021"


def _frame(body: str) -> bytes:
    return encode_frame(body)


# ---------------------------------------------------------------- the reported cases


@pytest.mark.parametrize(
    "value",
    [
        "1e3",
        "2_500.0",
        "+1.0",
        " 1.0",
        "1.0 ",
        "inf",
        "nan",
        "-inf",
        "1" * 200,
        "0." + "1" * 200,
        "1.",
        ".5",
        "--1.0",
        "0x10",
        "007.5",
        "1,0",
        "",
        "-",
    ],
)
def test_reading_value_outside_the_grammar_is_a_frame_error(value):
    fields = ("P3", value, "1.0", "2.0", "ACC", "5")
    with pytest.raises(FrameError):
        parse_reading(fields)


@pytest.mark.parametrize("t_us", ["-5", "+5", "1e3", "5.0", "0005", "1" * 40, ""])
def test_device_time_outside_the_grammar_is_a_frame_error(t_us):
    with pytest.raises(FrameError):
        parse_reading(("P3", "1.0", "2.0", "3.0", "ACC", t_us))


def test_lowercase_or_odd_crc_text_is_a_frame_error():
    frame = _frame(GOOD)
    crc = frame[-6:-2]
    for text in (crc.lower(), b"+" + crc[1:], b" " + crc[1:], b"0x" + crc[2:]):
        if text == crc:
            continue
        with pytest.raises(FrameError):
            decode_frame(frame[:-6] + text + b"\r\n")


def test_non_printable_body_is_a_frame_error():
    body = b"OK,4,\x01READY"
    with pytest.raises(FrameError):
        decode_frame(body + b"*%04X\r\n" % crc16(body))


@pytest.mark.parametrize("seq", ["0", "10000", "04", "-1", "+4", "4 "])
def test_reply_sequence_number_outside_1_to_9999_is_a_frame_error(seq):
    with pytest.raises(FrameError):
        parse_reply(f"OK,{seq},READY")


def test_event_must_carry_sequence_zero_and_a_plain_code():
    assert parse_reply("EV,0,6,BEAM_BROKEN").code == 6
    for body in ("EV,3,6,BEAM_BROKEN", "EV,0,-6,BEAM_BROKEN", "ER,4,1e1,X", "ER,4,,X"):
        with pytest.raises(FrameError):
            parse_reply(body)


def test_host_command_sequence_grammar():
    assert parse_command("12,MEAS").seq == 12
    for body in ("012,MEAS", "0,MEAS", "12,", "1_2,MEAS"):
        with pytest.raises(FrameError):
            parse_command(body)


def test_format_number_refuses_what_the_grammar_cannot_carry():
    with pytest.raises(ValueError):
        format_number(1e12, 4)
    with pytest.raises(ValueError):
        format_number(1.0, 12)


# ---------------------------------------------------------------- property tests


def _grammar_oracle(text: str) -> bool:
    """The number grammar written out by hand, independently of the regex in protocol.py."""
    body = text[1:] if text.startswith("-") else text
    whole, dot, frac = body.partition(".")
    digits = set(string.digits)
    if not whole or len(whole) > 9 or not set(whole) <= digits:
        return False
    if len(whole) > 1 and whole[0] == "0":
        return False
    if dot and (not frac or len(frac) > 9 or not set(frac) <= digits):
        return False
    return True


number_like = st.text(alphabet="0123456789-+._eE ,xin", max_size=14)


@settings(deadline=None)  # timing varies on a loaded machine; the cases are tiny
@given(number_like)
def test_parse_number_accepts_exactly_the_grammar(text):
    if _grammar_oracle(text):
        assert parse_number(text) == float(text)
    else:
        with pytest.raises(ValueError):
            parse_number(text)


@settings(deadline=None)  # timing varies on a loaded machine; the cases are tiny
@given(
    st.floats(-79_999.0, 79_999.0),
    st.floats(-79_999.0, 79_999.0),
    st.floats(-79_999.0, 79_999.0),
    st.one_of(st.none(), st.tuples(*[st.floats(-math.pi, math.pi)] * 3)),
    st.sampled_from(list(ReadingStatus)),
    st.integers(0, 10**15 - 1),
    st.integers(1, 9999),
)
def test_every_valid_reading_frame_round_trips(x, y, z, rot, status, t_us, seq):
    point = np.array([x, y, z])
    rotvec = None if rot is None else np.array(rot)
    frame = _frame(ok_body(seq, *reading_fields(point, rotvec, status, t_us)))
    assert len(frame) <= MAX_FRAME
    reply = parse_reply(decode_frame(frame))
    reading = parse_reading(reply.fields)
    assert reply.seq == seq and reading.status is status and reading.device_time_us == t_us
    np.testing.assert_allclose(reading.point_mm, point, atol=0.6e-4)
    if rotvec is not None:
        np.testing.assert_allclose(reading.rotvec_rad, rotvec, atol=0.6e-8)


def _mutations():
    """A valid reading field replaced by one text outside the grammar."""
    bad_number = st.one_of(
        st.from_regex(r"\A-?[0-9]{1,3}\.[0-9]{1,3}[eE][+-]?[0-9]{1,3}\Z"),
        st.from_regex(r"\A[0-9]{1,3}_[0-9]{1,3}\.[0-9]\Z"),
        st.from_regex(r"\A[0-9]{10,60}(\.[0-9])?\Z"),
        st.from_regex(r"\A[0-9]\.[0-9]{10,60}\Z"),
        st.from_regex(r"\A\+[0-9]{1,4}\.[0-9]{1,4}\Z"),
        st.sampled_from(["inf", "-inf", "nan", "Infinity", "NaN", "1.0 ", " 1.0"]),
    )
    return st.tuples(st.integers(1, 3), bad_number)


@settings(deadline=None)  # timing varies on a loaded machine; the cases are tiny
@given(_mutations())
def test_reading_with_any_value_outside_the_grammar_is_refused(mutation):
    index, text = mutation
    fields = list(GOOD.split(",")[2:])
    fields[index] = text
    body = "OK,4," + ",".join(fields)
    if len(body) + 7 > MAX_FRAME:
        return
    with pytest.raises(FrameError):
        parse_reading(parse_reply(decode_frame(_frame(body))).fields)


@settings(deadline=None)  # timing varies on a loaded machine; the cases are tiny
@given(st.binary(max_size=300))
def test_arbitrary_bytes_give_a_reading_or_a_frame_error(line):
    try:
        reply = parse_reply(decode_frame(line))
        parse_reading(reply.fields)
    except FrameError:
        pass


@settings(deadline=None)  # timing varies on a loaded machine; the cases are tiny
@given(st.text(alphabet=string.printable[:95].replace("*", ""), max_size=120))
def test_arbitrary_body_with_a_valid_crc_gives_a_reply_or_a_frame_error(body):
    try:
        frame = _frame(body)
    except ValueError:
        return
    try:
        reply = parse_reply(decode_frame(frame))
    except FrameError:
        return
    try:
        parse_reading(reply.fields)
    except FrameError:
        pass


frames = st.sampled_from(
    [_frame(GOOD), _frame("OK,3,P3,1.0,2.0,3.0,ACC,5"), _frame("EV,0,6,BEAM_BROKEN"), b"\r\n"]
)
stream = st.lists(st.one_of(frames, st.binary(max_size=400)), max_size=6).map(b"".join)


@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(stream)
def test_link_returns_only_the_reply_to_its_own_command_or_a_driver_error(data):
    # The port takes MEAS number 4 (the seq of GOOD) and then serves the generated bytes.
    link = Link(ScriptedTransport([(host(4, "MEAS"), data)]))
    link.counters.seq = 3
    try:
        reply = link.transact("MEAS", timeout_s=0.005)
    except DriverError:
        return
    assert reply.seq == 4
    assert parse_reading(reply.fields).point_mm.tolist() == [2500.0051, 399.9896, -300.0042]
    assert len(link._buf) <= MAX_FRAME


def _reading_frame(seq: int, x: float) -> bytes:
    return _frame(f"OK,{seq},P3,{x:.4f},1.0000,2.0000,ACC,{seq}")


junk = st.one_of(
    st.binary(max_size=300),
    st.sampled_from([b"\x7f" * 700, b"OK,3,P3*0000\r\n", b"\r\n", b"ER,2,6,BEAM_BROKEN"]),
    st.sampled_from([1, 2, 3]).map(lambda s: _reading_frame(s, 999.0)),  # stale replies
)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(junk, st.booleans()), min_size=1, max_size=5))
def test_over_many_commands_a_reading_is_always_its_own(script):
    """Junk, stale replies and missing replies between commands: whatever a call returns
    is the reply to that call (its x is 100 + seq), and the buffer stays bounded."""
    pairs = []
    for k, (noise, answered) in enumerate(script):
        seq = 4 + k
        pairs.append(
            (host(seq, "MEAS"), noise + (_reading_frame(seq, 100.0 + seq) if answered else b""))
        )
    link = Link(ScriptedTransport(pairs))
    link.counters.seq = 3
    for k in range(len(script)):
        try:
            reply = link.transact("MEAS", timeout_s=0.005)
        except DriverError:
            continue
        assert reply.seq == 4 + k
        assert parse_reading(reply.fields).point_mm[0] == 100.0 + reply.seq
        assert len(link._buf) <= MAX_FRAME
