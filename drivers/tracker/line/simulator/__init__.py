"""Simulated laser tracker speaking the product's tracker protocol.

Of the ``calibrator`` package it imports only the port contract and the one
simulated world's noise model (:class:`calibrator.simulate.NoiseModel`);
otherwise numpy (scipy for 6-DoF orientation noise) and
:mod:`drivers.tracker.line.protocol`.

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

from drivers.tracker.line.simulator.engine import HangUp, Send, TrackerSimulator
from drivers.tracker.line.simulator.faults import Fault, parse_fault, parse_script
from drivers.tracker.line.simulator.launch import SimulatorControl, SimulatorProcess
from drivers.tracker.line.simulator.noise import NoiseModel
from drivers.tracker.line.simulator.replay import ReplaySimulator
from drivers.tracker.line.simulator.server import SimulatorServer

__all__ = [
    "Fault",
    "HangUp",
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
