"""Simulated laser tracker speaking the product's tracker protocol.

The tracker itself is :class:`drivers.tracker.instrument.Instrument` (target,
noise, faults, air, warm-up, latency), the same one the emScon simulator
serves; this package is its line-protocol front-end (:mod:`.engine`), its
servers (pty and loopback TCP), its launcher and a replay of recorded logs.

In-process::

    sim = TrackerSimulator(seed=1, initialised=True)
    sim.set_target([2000.0, 0.0, 0.0])
    server = SimulatorServer(sim)
    url = server.open_pty()          # or f"socket://127.0.0.1:{server.open_tcp()}"
    server.start()

As a child process, target steered over a loopback control link::

    with SimulatorProcess(seed=1, initialised=True) as sim:
        sim.set_target([2000.0, 0.0, 0.0])
        tracker = LaserTracker(sim.url)

From a shell: ``python -m drivers.tracker.line.simulator --pty`` (see ``--help``).
"""

from drivers.tracker.instrument import (
    Fault,
    HangUp,
    Instrument,
    NoiseModel,
    Send,
    parse_fault,
    parse_script,
)
from drivers.tracker.line.simulator.engine import TrackerSimulator
from drivers.tracker.line.simulator.launch import SimulatorControl, SimulatorProcess
from drivers.tracker.line.simulator.replay import ReplaySimulator
from drivers.tracker.line.simulator.server import SimulatorServer

__all__ = [
    "Fault",
    "HangUp",
    "Instrument",
    "NoiseModel",
    "ReplaySimulator",
    "Send",
    "SimulatorControl",
    "SimulatorProcess",
    "SimulatorServer",
    "TrackerSimulator",
    "parse_fault",
    "parse_script",
]
