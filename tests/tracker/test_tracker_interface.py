"""One behavioural suite for the tracker port, run on every tracker kind.

Each kind is opened through the registry by its URL, as ``measure --tracker``
opens it: the line protocol over a pty (a device path) and over RFC 2217 in
front of that pty, emScon over a loopback socket, and the simulated tracker
(``sim://``, the simulator as a child process). The same failures must come
back under the same names whatever answers (``tests/robot/test_robot_interface.py``
does the same for robots).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from calibrator.acquire import ports
from calibrator.simulate import SimWorld
from drivers.tracker import OpenOptions, open_tracker
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator
from drivers.tracker.instrument import NoiseModel
from drivers.tracker.line.simulator import SimulatorServer, TrackerSimulator

# pyserial's own rfc2217 client still calls Thread.setDaemon/setName.
pytestmark = pytest.mark.filterwarnings(r"ignore:set(Daemon|Name)\(\) is deprecated")

TARGET_MM = np.array([2000.0, 300.0, -200.0])
#: Every kind reads the target exactly (noise off); what is left is the wire's rounding.
ATOL_MM = 1e-3


@dataclass
class Harness:
    """One tracker kind: how to open it and steer or upset its simulator.

    ``open(beam_breaks)`` returns the unconnected tracker; its next ``beam_breaks``
    measurements find the beam broken.
    """

    open: Callable[[int], ports.Tracker]
    steer: Callable[[ports.Tracker, np.ndarray], None]


def _scripted(sim, url: Callable[[], str]) -> Callable[[int], ports.Tracker]:
    """``open(beam_breaks)`` of a simulator engine served in this process."""

    def open_(beam_breaks: int) -> ports.Tracker:
        if beam_breaks:
            sim.arm_fault(f"MEAS+1 beam_break count={beam_breaks}")
        return open_tracker(url())

    return open_


@pytest.fixture(params=["line-pty", "rfc2217", "emscon", "sim"])
def harness(request, tmp_path) -> Iterator[Harness]:
    kind = request.param
    stops: list[Callable[[], None]] = []
    if kind in ("line-pty", "rfc2217"):
        sim = TrackerSimulator(seed=11, initialised=True, noise=NoiseModel(enabled=False))
        server = SimulatorServer(sim)
        url = server.open_pty()  # a device path: the line-protocol kind
        server.start()
        stops.append(server.stop)
        if kind == "rfc2217":
            pytest.importorskip("serial.rfc2217")
            from tracker_kit import Rfc2217Bridge

            bridge = Rfc2217Bridge(url)
            stops.append(bridge.close)
            url = f"rfc2217://127.0.0.1:{bridge.port}"
        sim.set_target(TARGET_MM)
        yield Harness(_scripted(sim, lambda: url), lambda tracker, point: sim.set_target(point))
    elif kind == "emscon":
        emscon = EmsconSimulator(seed=13, initialised=True, noise=NoiseModel(enabled=False))
        emscon.set_target(TARGET_MM)
        served = EmsconServer(emscon)
        served.open()
        served.start()
        stops.append(served.stop)
        yield Harness(
            _scripted(emscon, lambda: f"emscon://127.0.0.1:{served.port}"),
            lambda tracker, point: emscon.set_target(point),
        )
    else:
        world = SimWorld.make("ur10e", 1)

        def open_sim(beam_breaks: int) -> ports.Tracker:
            url = "sim://?noise=off"
            if beam_breaks:
                script = Path(tmp_path) / "faults.txt"
                script.write_text(f"MEAS@1 beam_break count={beam_breaks}\n")
                url += f"&faults={script}"
            return open_tracker(url, OpenOptions(world=world))

        def steer(tracker: ports.Tracker, point: np.ndarray) -> None:
            assert ports.STEER.offered_by(tracker)
            tracker.set_target(point)

        yield Harness(open_sim, steer)
    for stop in reversed(stops):
        stop()


def test_every_kind_satisfies_the_port_and_offers_what_it_declares(harness):
    tracker = harness.open(0)
    try:
        assert isinstance(tracker, ports.Tracker)
        declared = {
            name: value
            for name, value in vars(ports).items()
            if isinstance(value, ports.Capability) and value in tracker.capabilities
        }
        assert declared, "every tracker kind declares at least that it can be initialised"
        for name, capability in declared.items():
            assert capability.offered_by(tracker), f"{name} declared but its methods are missing"
    finally:
        tracker.close()


def test_every_kind_connects_initialised_and_reads_the_target_in_mm(harness):
    tracker = harness.open(0)
    try:
        state = tracker.connect()
        assert state.initialised and tracker.status().initialised
        assert tracker.device_id  # a journal records who answered
        harness.steer(tracker, TARGET_MM)
        reading = tracker.measure()
        assert isinstance(reading, ports.TrackerReading) and reading.accurate
        np.testing.assert_allclose(reading.point_mm, TARGET_MM, atol=ATOL_MM)
        moved = TARGET_MM + [10.0, -5.0, 2.5]
        harness.steer(tracker, moved)
        np.testing.assert_allclose(tracker.measure().point_mm, moved, atol=ATOL_MM)
    finally:
        tracker.close()


def test_every_kind_reports_a_broken_beam_as_the_ports_beam_lost_then_reads_again(harness):
    tracker = harness.open(1)
    try:
        tracker.connect()
        harness.steer(tracker, TARGET_MM)
        with pytest.raises(ports.BeamLost):
            tracker.measure()
        np.testing.assert_allclose(tracker.measure().point_mm, TARGET_MM, atol=ATOL_MM)
    finally:
        tracker.close()


def test_every_kind_closes_twice_and_refuses_to_measure_once_closed(harness):
    tracker = harness.open(0)
    tracker.connect()
    tracker.close()
    tracker.close()
    with pytest.raises((ports.PortError, OSError)):
        tracker.measure()
