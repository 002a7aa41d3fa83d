"""Link integrity: a reading belongs to the pose it is reported for (issue 8, items 1-3).

Each test reproduces one way a reading went wrong or a call hung: a late
reply after a reconnect, a long burst of junk, a device that stops reading.
"""

from __future__ import annotations

import os
import threading
import time
import tty

import numpy as np
import pytest
import serial
from tracker_kit import DevicePort, engine_responder

from drivers.tracker import ConnectionLost, FrameError, LaserTracker, TrackerTimeout
from drivers.tracker.instrument import NoiseModel
from drivers.tracker.line.protocol import MAX_FRAME, SEQ_MAX
from drivers.tracker.line.simulator import TrackerSimulator


def _exact_sim():
    sim = TrackerSimulator(seed=1, initialised=True, noise=NoiseModel(enabled=False))
    sim.set_target([1000.0, 0.0, 0.0])
    return sim


def _pose(sim, k):
    """Put the target of pose ``k`` in place; return its true point (mm)."""
    point = np.array([1000.0 + 100.0 * k, 50.0, -20.0])
    sim.set_target(point)
    return point


# ---------------------------------------------------------------- item 1


@pytest.mark.parametrize("failing_pose", [0, 1, 2])
def test_late_reply_after_reconnect_is_never_reported_for_the_next_pose(failing_pose):
    """The device answers MEAS after 300 ms; the port fails once while a MEAS waits."""
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim, meas_delay_s=0.3))
    tracker = LaserTracker(port, measure_timeout_s=2.0, reconnect_delay_s=0.01)
    tracker.connect()
    got = {}
    for k in range(4):
        truth = _pose(sim, k)
        if k == failing_pose:
            port.fail_reads = 1  # SerialException mid-command, after MEAS was written
            with pytest.raises(ConnectionLost, match="not repeated"):
                tracker.measure()
            continue
        reading = tracker.measure()
        got[k] = reading.point_mm
        np.testing.assert_allclose(reading.point_mm, truth, atol=1e-9, err_msg=f"pose {k}")
    assert len(got) == 3
    # The late reply to the lost MEAS arrived and was dropped, and counted.
    assert tracker.stale_replies == 1


def test_sequence_numbers_continue_across_reconnects():
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port, reconnect_delay_s=0.0)
    tracker.connect()
    before = tracker.link.last_seq
    port.fail_reads = 1
    with pytest.raises(ConnectionLost):
        tracker.measure()
    # Reconnect sent ID?, UNITS, STAT? with the numbers after the lost MEAS, not from 1.
    assert tracker.link.last_seq == before + 4
    tracker.measure()
    assert tracker.link.last_seq == before + 5


# ---------------------------------------------------------------- item 2


def test_one_megabyte_without_line_end_costs_at_most_one_reading():
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port, measure_timeout_s=1.0)
    tracker.connect()
    port.rx += b"\x7f" * (1 << 20)  # a burst of line noise, no line end
    failures = 0
    for k in range(5):
        truth = _pose(sim, k)
        try:
            reading = tracker.measure()
        except FrameError:
            failures += 1
            continue
        np.testing.assert_allclose(reading.point_mm, truth, atol=1e-9)
    assert failures <= 1
    assert tracker.discarded_bytes >= 1 << 20


def test_junk_glued_to_the_front_of_a_reply_is_discarded_and_the_reply_read():
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port)
    tracker.connect()
    port.rx += b"garbage-before-the-reply"
    truth = _pose(sim, 1)
    np.testing.assert_allclose(tracker.measure().point_mm, truth)
    assert tracker.discarded_bytes == len(b"garbage-before-the-reply")


def test_endless_line_keeps_memory_bounded_and_times_out():
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port, reconnect_attempts=0)
    tracker.connect()
    port.junk, port.endless_junk = b"A" * 4096, True
    started = time.monotonic()
    with pytest.raises((TrackerTimeout, FrameError)):
        tracker.measure(timeout_s=0.2)
    with pytest.raises((TrackerTimeout, FrameError)):
        tracker.measure(timeout_s=0.2)
    assert time.monotonic() - started < 2.0
    assert len(tracker.link._buf) <= 2 * MAX_FRAME
    assert tracker.discarded_bytes > 65536
    # When the device stops, the link comes back.
    port.endless_junk = False
    port.rx.clear()
    port.rx += b"tail of the junk\r\n"
    truth = _pose(sim, 3)
    np.testing.assert_allclose(tracker.measure(timeout_s=1.0).point_mm, truth)


# ---------------------------------------------------------------- item 3


@pytest.fixture
def stuck_pty():
    """A pty whose device answers connect, then stops reading with its input buffer full."""
    master, slave = os.openpty()
    tty.setraw(slave)
    path = os.ttyname(slave)
    sim = _exact_sim()
    stop = threading.Event()

    def device(n_lines=3):
        buf = b""
        while n_lines and not stop.is_set():
            buf += os.read(master, 256)
            while b"\r\n" in buf and n_lines:
                line, buf = buf.split(b"\r\n", 1)
                for out in sim.handle_line(line + b"\r\n"):
                    os.write(master, out.data)
                n_lines -= 1

    thread = threading.Thread(target=device, daemon=True)
    thread.start()
    yield path, thread
    stop.set()
    os.set_blocking(master, False)
    try:
        while os.read(master, 65536):
            pass
    except OSError:
        pass
    os.close(master)
    os.close(slave)


def _fill_towards_device(path):
    fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK | os.O_NOCTTY)
    try:
        for size in (4096, 64, 1):  # a pty takes a short write while a long one would block
            try:
                while True:
                    os.write(fd, b"x" * size)
            except BlockingIOError:
                pass
    finally:
        os.close(fd)


def test_measure_is_bounded_by_its_deadline_when_the_device_stops_reading(stuck_pty):
    path, device = stuck_pty
    tracker = LaserTracker(path, timeout_s=2.0, reconnect_attempts=0)
    tracker.connect()
    device.join(timeout=5)
    _fill_towards_device(path)
    outcome = {}

    def call():
        started = time.monotonic()
        try:
            tracker.measure(timeout_s=0.01)
        except Exception as exc:  # noqa: BLE001 - the test inspects whatever came out
            outcome["error"] = exc
        outcome["elapsed"] = time.monotonic() - started

    worker = threading.Thread(target=call, daemon=True)
    worker.start()
    worker.join(timeout=5.0)
    assert not worker.is_alive(), "measure() blocked in write() past its deadline"
    assert isinstance(outcome.get("error"), TrackerTimeout)
    assert outcome["elapsed"] < 1.0
    tracker.close()


def test_sequence_wraps_but_the_wrapped_number_is_not_ambiguous():
    """After SEQ_MAX commands the number repeats; by then the old reply is long gone."""
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port)
    tracker.connect()
    tracker.link.counters.seq = SEQ_MAX - 1
    for k in range(3):
        truth = _pose(sim, k)
        np.testing.assert_allclose(tracker.measure().point_mm, truth)
    assert tracker.link.last_seq == 2


def test_one_megabyte_burst_over_a_real_pty_costs_at_most_one_reading():
    """The same burst through pyserial on a pty: the device sends 1 MiB of junk, then replies."""
    master, slave = os.openpty()
    tty.setraw(slave)
    sim = _exact_sim()
    burst = threading.Event()
    stop = threading.Event()

    def device():
        buf = b""
        while not stop.is_set():
            try:
                buf += os.read(master, 4096)
            except OSError:
                return
            while b"\r\n" in buf:
                line, buf = buf.split(b"\r\n", 1)
                if b"MEAS" in line and burst.is_set():
                    burst.clear()
                    os.write(master, b"\x7f" * (1 << 20))  # blocks until the driver reads it
                for out in sim.handle_line(line + b"\r\n"):
                    os.write(master, out.data)

    thread = threading.Thread(target=device, daemon=True)
    thread.start()
    tracker = LaserTracker(os.ttyname(slave), timeout_s=5.0, measure_timeout_s=5.0)
    try:
        tracker.connect()
        burst.set()
        failures = 0
        for k in range(4):
            truth = _pose(sim, k)
            try:
                np.testing.assert_allclose(tracker.measure().point_mm, truth, atol=1e-9)
            except FrameError:
                failures += 1
        assert failures <= 1
        assert tracker.discarded_bytes >= 1 << 20
    finally:
        tracker.close()
        stop.set()
        os.close(slave)
        os.close(master)
        thread.join(timeout=5)


def test_after_a_write_timeout_the_next_frame_ends_the_part_written_line():
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port, reconnect_attempts=0)
    tracker.connect()
    written = []
    real_write = port.write

    def stuck_write(data):
        port.write = recording_write
        real_write(data[:4])  # part of the frame went out, then the device stopped reading
        raise serial.SerialTimeoutException("Write timeout")

    def recording_write(data):
        written.append(data)
        return real_write(data)

    port.write = stuck_write
    with pytest.raises(TrackerTimeout, match="not reading"):
        tracker.measure(timeout_s=0.5)
    truth = _pose(sim, 1)
    np.testing.assert_allclose(tracker.measure().point_mm, truth)
    assert written[0].startswith(b"\r\n")  # the device answered BAD_FRAME to the fragment
    assert tracker.link.port.write_timeout is not None


def test_an_echo_of_our_own_frames_is_dropped_and_counted():
    sim = _exact_sim()
    respond = engine_responder(sim)
    port = DevicePort(lambda line: [(0.0, line), *respond(line)])  # a device that echoes
    tracker = LaserTracker(port)
    tracker.connect()
    truth = _pose(sim, 2)
    np.testing.assert_allclose(tracker.measure().point_mm, truth)
    assert tracker.stale_replies == tracker.link.last_seq  # one echo per command sent


def test_a_partial_write_is_a_timeout_and_the_next_command_works():
    sim = _exact_sim()
    port = DevicePort(engine_responder(sim))
    tracker = LaserTracker(port, reconnect_attempts=0)
    tracker.connect()
    real_write = port.write

    def short_write(data):  # what pyserial does with write_timeout=0 on a full buffer
        port.write = real_write
        return real_write(data[:3])

    port.write = short_write
    with pytest.raises(TrackerTimeout, match="partial"):
        tracker.measure()
    truth = _pose(sim, 1)
    np.testing.assert_allclose(tracker.measure().point_mm, truth)
