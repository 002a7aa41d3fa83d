"""One simulated tracker, two wires: the line protocol and Leica emScon drive the same
:class:`~drivers.tracker.instrument.Instrument`, so what it does (noise, warm-up, air)
is seen the same through either, over a real pty and real loopback TCP. Every wait is
bounded by the drivers' deadlines (``timeout_s``) and the servers' joins.
"""

from __future__ import annotations

import socket
import subprocess
import sys
from collections import deque

import numpy as np
import pytest
from tracker_kit import REPO

from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.link import EmsconLink
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator, EmsconSimulatorProcess
from drivers.tracker.instrument import WARM_UP_S, Instrument
from drivers.tracker.line.device import LaserTracker
from drivers.tracker.line.simulator import SimulatorServer, TrackerSimulator

TARGET_MM = np.array([2500.0, 300.0, -200.0])
AIR = (23.5, 990.0, 38.0)  # not the standard air either front-end assumes
#: The line protocol writes points with 4 decimals (0.1 um); emScon sends doubles.
WIRE_MM = 1e-4


class Clock:
    """A clock the test moves by hand (the instrument's; the servers keep the wall clock)."""

    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


def _line(instrument: Instrument) -> tuple[SimulatorServer, LaserTracker]:
    server = SimulatorServer(TrackerSimulator(instrument=instrument))
    url = server.open_pty()
    server.start()
    tracker = LaserTracker(url)
    tracker.connect()
    return server, tracker


def _emscon(instrument: Instrument, air=None) -> tuple[EmsconServer, EmsconTracker]:
    server = EmsconServer(EmsconSimulator(instrument=instrument, air=air))
    server.open()
    server.start()
    # No environment sent: the server's own (its weather station's, when it has one).
    tracker = EmsconTracker("127.0.0.1", server.port, environment=None, timeout_s=2.0)
    tracker.connect()
    return server, tracker


def _system_status(port: int) -> pk.SystemStatus:
    """``GetSystemStatus`` over a connection of its own (the adapter does not keep it all)."""
    link = EmsconLink(
        socket.create_connection(("127.0.0.1", port), 2.0), events=deque(), packet_gap_s=1.0
    )
    try:
        reply = link.transact(pk.Command.GET_SYSTEM_STATUS, timeout_s=2.0)
    finally:
        link.close()
    return pk.parse_system_status(reply.body)


def _readings(tracker, n: int) -> np.ndarray:
    return np.array([tracker.measure().point_mm for _ in range(n)])


def test_the_same_seed_gives_the_same_noisy_readings_through_both_wires():
    line_inst, emscon_inst = (Instrument(seed=11, initialised=True) for _ in range(2))
    for inst in (line_inst, emscon_inst):
        inst.set_target(TARGET_MM)
    line_server, line = _line(line_inst)
    emscon_server, emscon = _emscon(emscon_inst)
    try:
        by_line, by_emscon = _readings(line, 5), _readings(emscon, 5)
    finally:
        line.close(), emscon.close(), line_server.stop(), emscon_server.stop()
    np.testing.assert_allclose(by_line, by_emscon, atol=WIRE_MM)
    scatter = np.linalg.norm(by_line - TARGET_MM, axis=1)
    assert np.all(scatter > 1e-3) and np.all(scatter < 0.2)  # noisy, as the model's microns


def test_warm_up_and_air_of_one_instrument_are_seen_the_same_through_both_wires():
    clock = Clock()
    inst = Instrument(seed=3, initialised=True, clock=clock, air=AIR, on_s=WARM_UP_S - 10.0)
    inst.set_target(TARGET_MM)
    line_server, line = _line(inst)
    emscon_server, emscon = _emscon(inst, air=AIR)  # the station measures the instrument's air
    try:
        cold_line, cold_laser = line.conditions(), _system_status(emscon_server.port).laser
        emscon_air = emscon.conditions()
        clock.now += 20.0
        warm_line, warm_laser = line.conditions(), _system_status(emscon_server.port).laser
        # One target: moved through the line's control commands, read through emScon.
        line.send("SIM", "TARGET", "3000", "0", "0")
        moved = emscon.measure().point_mm
    finally:
        line.close(), emscon.close(), line_server.stop(), emscon_server.stop()
    assert cold_line is not None and warm_line is not None
    assert (cold_line["warmed_up"], cold_laser) == (False, pk.LaserStatus.HEATING_UP)
    assert (warm_line["warmed_up"], warm_laser) == (True, pk.LaserStatus.READY)
    assert warm_line["on_s"] == pytest.approx(WARM_UP_S + 10.0)
    line_air = tuple(
        cold_line[k] for k in ("air_temperature_c", "air_pressure_hpa", "air_humidity_pct")
    )
    assert line_air == pytest.approx(AIR)
    assert tuple(emscon_air.values()) == pytest.approx(AIR)
    np.testing.assert_allclose(moved, [3000.0, 0.0, 0.0], atol=0.2)


def test_the_emscon_simulator_process_takes_air_and_power_on_time_from_its_command_line():
    with EmsconSimulatorProcess(seed=1, initialised=True, air=AIR, on_s=60.0) as sim:
        sim.set_target(TARGET_MM)
        status = _system_status(sim.port)
        tracker = EmsconTracker("127.0.0.1", sim.port, environment=None, timeout_s=2.0)
        tracker.connect()
        try:
            said = tracker.conditions()
        finally:
            tracker.close()
    assert status.laser == pk.LaserStatus.HEATING_UP  # one minute on: still warming up
    assert status.weather_monitor == pk.WeatherMonitor.READ_AND_CALCULATE
    assert tuple(said.values()) == pytest.approx(AIR)


def test_without_a_weather_station_emscon_corrects_with_the_client_air_as_before():
    server = EmsconServer(EmsconSimulator(seed=1, initialised=True))
    server.open()
    server.start()
    try:
        status = _system_status(server.port)
    finally:
        server.stop()
    assert (status.laser, status.weather_monitor) == (pk.LaserStatus.READY, 0)


@pytest.mark.parametrize(
    "option", [["--air", "20,1013"], ["--on-time", "-3"], ["--time-scale", "0"]]
)
def test_a_bad_emscon_simulator_option_is_one_line_and_exit_2(option):
    done = subprocess.run(
        [sys.executable, "-m", "drivers.tracker.emscon.simulator", *option],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and f"argument {option[0]}:" in done.stderr
