"""Pure protocol functions: CRC, framing, parsing, fault scripts, noise model frame."""

from __future__ import annotations

import binascii

import numpy as np
import pytest

from drivers.tracker.errors import ChecksumError, FrameError
from drivers.tracker.instrument import NoiseModel, beam_frame
from drivers.tracker.instrument.faults import FaultSchedule, parse_fault, parse_script
from drivers.tracker.line.protocol import (
    MAX_FRAME,
    ErrorCode,
    ReadingStatus,
    ReplyKind,
    command_body,
    crc16,
    decode_frame,
    encode_frame,
    error_body,
    format_number,
    next_seq,
    parse_command,
    parse_reading,
    parse_reply,
    reading_fields,
)


def test_crc16_is_ccitt_false_check_value():
    # 0x29B1 is the published check value of CRC-16/CCITT-FALSE for "123456789".
    assert crc16(b"123456789") == 0x29B1


def test_encode_frame_layout():
    frame = encode_frame("7,MEAS")
    assert frame == b"7,MEAS*%04X\r\n" % binascii.crc_hqx(b"7,MEAS", 0xFFFF)
    assert decode_frame(frame) == "7,MEAS"
    assert decode_frame(frame[:-2]) == "7,MEAS"  # terminator optional when decoding


@pytest.mark.parametrize("body", ["a*b", "a\rb", "a\nb", "x" * MAX_FRAME])
def test_encode_frame_rejects_bad_bodies(body):
    with pytest.raises(ValueError):
        encode_frame(body)


def test_decode_frame_detects_any_single_flipped_byte():
    frame = encode_frame("OK,12,P3,1.0000,2.0000,3.0000,ACC,42")
    for i in range(len(frame) - 7):  # every body byte
        damaged = bytearray(frame)
        damaged[i] ^= 0x01
        with pytest.raises((ChecksumError, FrameError)):
            decode_frame(bytes(damaged))


@pytest.mark.parametrize(
    "line", [b"OK,1,READY\r\n", b"OK,1*12\r\n", b"OK,1*ZZZZ\r\n", b"\xff\xfe*0000\r\n"]
)
def test_decode_frame_rejects_garbage(line):
    with pytest.raises(FrameError):
        decode_frame(line)


def test_sequence_numbers_wrap_and_skip_zero():
    assert next_seq(0) == 1 and next_seq(1) == 2 and next_seq(9999) == 1
    with pytest.raises(ValueError):
        command_body(0, "MEAS")


def test_command_roundtrip_and_field_checks():
    cmd = parse_command(command_body(42, "ENV", "20.00", "1013.25", "50.0"))
    assert (cmd.seq, cmd.name, cmd.args) == (42, "ENV", ("20.00", "1013.25", "50.0"))
    with pytest.raises(ValueError):
        command_body(1, "ENV", "1,2")
    with pytest.raises(FrameError):
        parse_command("MEAS")


def test_reply_parsing():
    ok = parse_reply("OK,5,READY,1")
    assert ok.kind is ReplyKind.OK and ok.seq == 5 and ok.fields == ("READY", "1")
    er = parse_reply(error_body(9, ErrorCode.BEAM_BROKEN, "lost, at 3 m"))
    assert er.kind is ReplyKind.ER and er.code == 6 and er.text == "BEAM_BROKEN"
    assert er.detail == "lost; at 3 m"  # commas in details are replaced, not split
    ev = parse_reply(error_body(0, ErrorCode.BEAM_RESTORED))
    assert ev.kind is ReplyKind.EV and ev.seq == 0 and ev.code == 20
    for bad in ("XX,1,2", "OK,one", "ER,3", "ER,3,BEAM"):
        with pytest.raises(FrameError):
            parse_reply(bad)


def test_reading_fields_roundtrip():
    fields = reading_fields(np.array([1.23456, -0.0, 7.0]), None, ReadingStatus.INACCURATE, 99)
    assert fields == ("P3", "1.2346", "0.0000", "7.0000", "INACC", "99")
    reading = parse_reading(fields)
    np.testing.assert_array_equal(reading.point_mm, [1.2346, 0.0, 7.0])
    assert reading.status is ReadingStatus.INACCURATE and reading.rotvec_rad is None
    six = parse_reading(
        reading_fields(np.ones(3), np.array([0.1, 0, 0]), ReadingStatus.ACCURATE, 1)
    )
    np.testing.assert_array_equal(six.rotvec_rad, [0.1, 0.0, 0.0])


def test_format_number_refuses_non_finite():
    with pytest.raises(ValueError):
        format_number(float("nan"), 3)


def test_fault_script_parsing_and_schedule():
    faults = parse_script(
        """
        # comment
        MEAS@2 beam_break count=3   # trailing comment
        *@4 hangup
        STAT?+1 error code=BUSY
        MEAS@3 partial delay=0.25
        """
    )
    assert [(f.command, f.nth, f.kind) for f in faults] == [
        ("MEAS", 2, "beam_break"),
        ("*", 4, "hangup"),
        ("STAT?", 1, "error"),
        ("MEAS", 3, "partial"),
    ]
    assert faults[0].count == 3 and faults[2].code is ErrorCode.BUSY and faults[3].delay_s == 0.25
    schedule = FaultSchedule(faults)
    hits = [[f.kind for f in schedule.next_command(c)] for c in ("MEAS", "STAT?", "MEAS", "MEAS")]
    assert hits == [[], ["error"], ["beam_break"], ["hangup", "partial"]]
    for bad in ("MEAS beam_break", "MEAS@0 drop", "MEAS@1 explode", "MEAS@1 drop speed=3"):
        with pytest.raises(ValueError):
            parse_fault(bad)


def test_relative_fault_counts_from_arming():
    schedule = FaultSchedule()
    schedule.next_command("MEAS")
    schedule.next_command("MEAS")
    schedule.arm(parse_fault("MEAS+2 drop"))
    assert [bool(schedule.next_command("MEAS")) for _ in range(3)] == [False, True, False]


def test_beam_frame_is_orthonormal_with_beam_first():
    for p in ([3000.0, 0, 0], [0, 0, 2500.0], [1000.0, -2000.0, 500.0]):
        frame = np.array(beam_frame(np.array(p)))
        np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(frame[0], np.array(p) / np.linalg.norm(p))


def test_noise_sigmas_follow_the_mpe_formula():
    along, trans = NoiseModel().sigmas_mm(np.array([0.0, 4000.0, 0.0]))
    assert along == pytest.approx((10 + 0.3 * 4) / 2 / 1000)
    assert trans == pytest.approx((15 + 6 * 4) / 2 / 1000)


def test_noise_off_is_exact_and_seeded_noise_repeats():
    p = np.array([1000.0, 2000.0, 300.0])
    np.testing.assert_array_equal(
        NoiseModel(enabled=False).sample_point(p, np.random.default_rng(0)), p
    )
    a = NoiseModel().sample_point(p, np.random.default_rng(5))
    b = NoiseModel().sample_point(p, np.random.default_rng(5))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, p)
