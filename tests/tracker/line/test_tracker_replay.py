"""Recorded streams in fixtures/tracker/ replay through the simulator to the same readings.

The fixtures were produced by this module's scenarios against the seeded
live simulator with the driver recording; regenerate them with
``.venv/bin/python tests/tracker/line/test_tracker_replay.py``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from tracker_kit import REPO, live_tracker

from drivers.errors import DriverError
from drivers.tracker import Environment, measure_average, read_log
from drivers.tracker.line.protocol import (
    ReplyKind,
    decode_frame,
    encode_frame,
    parse_reading,
    parse_reply,
)
from drivers.tracker.line.simulator import (
    ReplaySimulator,
    SimulatorServer,
    TrackerSimulator,
    parse_script,
)

FIXTURES = REPO / "fixtures" / "tracker"
MEAS_TIMEOUT_S = 0.25


def _outcome(func):
    """A reading, or the name of the typed error it raised."""
    try:
        return func()
    except DriverError as exc:
        return type(exc).__name__


def scenario_session_3dof(tracker):
    """Connect with meteo data, initialise, one 10-reading set, stop."""
    tracker.connect(Environment(20.5, 1012.0, 45.0), mode="STANDARD")
    tracker.initialise()
    readings = list(measure_average(tracker, 10).readings)
    tracker.stop()
    return readings


def scenario_session_6dof(tracker):
    """A 6-DoF probe: five readings with orientation."""
    tracker.connect()
    return [tracker.measure() for _ in range(5)]


def scenario_faults(tracker):
    """Single readings through unstable readings, a beam break, a bad checksum, a dropped
    and a split reply."""
    tracker.connect()
    # Only the two replies that never come complete get the short deadline.
    timeouts = [MEAS_TIMEOUT_S if i in (8, 10) else None for i in range(13)]
    return [_outcome(lambda t=t: tracker.measure(timeout_s=t)) for t in timeouts]


FAULT_OUTCOMES = [
    "ACC", "UNSTABLE", "UNSTABLE", "ACC", "BeamBroken", "ACC", "ACC",
    "ChecksumError", "TrackerTimeout", "ACC", "TrackerTimeout", "ACC", "ACC",
]  # fmt: skip


SCENARIOS = {
    "session_3dof": (
        scenario_session_3dof,
        dict(seed=21, target=([2500.0, 400.0, -300.0], None)),
    ),
    "session_6dof": (
        scenario_session_6dof,
        dict(
            seed=22,
            probe_6dof=True,
            initialised=True,
            target=([1800.0, -600.0, 250.0], [0.2, 0.1, -1.0]),
        ),
    ),
    "faults": (
        scenario_faults,
        dict(
            seed=23,
            initialised=True,
            target=([3200.0, 0.0, 150.0], None),
            faults="MEAS@2 unstable count=2\n"
            "MEAS@5 beam_break\n"
            "MEAS@8 bad_crc\n"
            "MEAS@9 drop\n"
            "MEAS@11 partial delay=0.4\n",  # the driver gives up at MEAS_TIMEOUT_S
        ),
    ),
}


def record_fixture(name: str, path: Path) -> list:
    """Run a scenario against the live seeded simulator, recording to ``path``."""
    scenario, opts = SCENARIOS[name]
    opts = dict(opts)
    point, rotvec = opts.pop("target")
    faults = parse_script(opts.pop("faults", ""))
    sim = TrackerSimulator(init_time_s=0.05, faults=faults, **opts)
    sim.set_target(point, rotvec)
    with SimulatorServer(sim) as server:
        url = server.open_pty()
        server.start()
        with live_tracker(url, record=path) as tracker:
            return scenario(tracker)


def recorded_readings(path: Path) -> list:
    """The MEAS readings a log holds as answers to their own command (stale lines excluded)."""
    readings, seq, pending = [], 0, b""
    for entry in read_log(path):
        if entry.direction == "tx":
            seq = int(entry.data.split(b",", 1)[0])
            continue
        pending += entry.data
        *lines, pending = pending.split(b"\r\n")
        for line in lines:
            try:
                reply = parse_reply(decode_frame(line))
            except DriverError:
                continue  # garbled or bad-checksum lines carry no reading
            if (
                reply.kind is ReplyKind.OK
                and reply.seq == seq
                and reply.fields[:1] in (("P3",), ("P6",))
            ):
                readings.append(parse_reading(reply.fields))
    return readings


def same_reading(a, b) -> bool:
    return (
        np.array_equal(a.point_mm, b.point_mm)
        and (a.rotvec_rad is None) == (b.rotvec_rad is None)
        and (a.rotvec_rad is None or np.array_equal(a.rotvec_rad, b.rotvec_rad))
        and a.status == b.status
        and a.device_time_us == b.device_time_us
    )


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_replay_reproduces_recorded_readings(name, sim_process, tmp_path):
    fixture = FIXTURES / f"{name}.jsonl"
    expected = recorded_readings(fixture)
    assert len(expected) >= 5
    _, (path,) = sim_process("--pty", "--replay", str(fixture))
    replay_log = tmp_path / "replay.jsonl"
    with live_tracker(path, record=replay_log) as tracker:
        outcomes = SCENARIOS[name][0](tracker)
    got = [o for o in outcomes if not isinstance(o, str)]
    # The readings the driver returned are exactly the recorded ones, in order.
    assert len(got) == len(expected)
    assert all(same_reading(a, b) for a, b in zip(got, expected, strict=True))
    if name == "faults":
        labels = [o if isinstance(o, str) else o.status.value for o in outcomes]
        assert labels == FAULT_OUTCOMES
    # Byte for byte: the same frames went out and the same bytes came back.
    rec, rep = read_log(fixture), read_log(replay_log)
    for direction in ("tx", "rx"):
        assert b"".join(e.data for e in rep if e.direction == direction) == b"".join(
            e.data for e in rec if e.direction == direction
        )


def test_replay_refuses_a_different_command_sequence(tmp_path):
    fixture = FIXTURES / "session_6dof.jsonl"
    with SimulatorServer(ReplaySimulator(fixture)) as server:
        url = server.open_pty()
        server.start()
        with live_tracker(url) as tracker:
            tracker.connect()
            tracker.send("SIM", "TARGET", "1", "2", "3")  # control frames are accepted, not matched
            with pytest.raises(DriverError, match="REPLAY_MISMATCH"):
                tracker.initialise()


def main() -> int:
    FIXTURES.mkdir(parents=True, exist_ok=True)
    for name in SCENARIOS:
        outcomes = record_fixture(name, FIXTURES / f"{name}.jsonl")
        print(name, [o if isinstance(o, str) else o.status.value for o in outcomes])
    return 0


if __name__ == "__main__":
    sys.exit(main())


def test_replay_renumbers_replies_for_a_shifted_sequence():
    """A host that numbers its frames differently still gets the recorded values."""
    fixture = FIXTURES / "session_6dof.jsonl"
    replay = ReplaySimulator(fixture)
    recorded = recorded_readings(fixture)
    tx = [e.data for e in read_log(fixture) if e.direction == "tx"]
    got = []
    for frame in tx:
        seq, rest = frame.split(b",", 1)
        shifted = encode_frame(f"{int(seq) + 100},{rest.decode()[: rest.index(b'*')]}")
        out = b"".join(o.data for o in replay.handle_line(shifted))
        reply = parse_reply(decode_frame(out.split(b"\r\n")[0]))
        assert reply.seq == int(seq) + 100
        if reply.fields[:1] == ("P6",):
            got.append(parse_reading(reply.fields))
    assert len(got) == len(recorded) and all(map(same_reading, got, recorded))
    assert replay.remaining == 0
    end = parse_reply(decode_frame(replay.handle_line(encode_frame("1,MEAS"))[0].data))
    assert end.code == 90 and "end of recording" in end.detail
