"""Simulated Leica emScon server on loopback TCP (see :mod:`.engine` for the faults)."""

from drivers.tracker.emscon.simulator.engine import EmsconSimulator
from drivers.tracker.emscon.simulator.launch import EmsconSimulatorProcess
from drivers.tracker.emscon.simulator.server import EmsconServer

__all__ = ["EmsconServer", "EmsconSimulator", "EmsconSimulatorProcess"]
