"""Fixtures: an emScon simulator served on loopback TCP in a thread, and an adapter on it."""

from __future__ import annotations

import pytest
from emscon_kit import ENV, TARGET_MM

from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator
from drivers.tracker.instrument import NoiseModel


@pytest.fixture
def sim():
    """An initialised, seeded simulator with a target 2 m away, not yet served."""
    simulator = EmsconSimulator(seed=13, initialised=True, init_time_s=0.05)
    simulator.set_target(TARGET_MM)
    return simulator


@pytest.fixture
def exact_sim():
    """Like ``sim`` but with exact readings (noise disabled)."""
    simulator = EmsconSimulator(seed=13, initialised=True, noise=NoiseModel(enabled=False))
    simulator.set_target(TARGET_MM)
    return simulator


def _serve(engine):
    server = EmsconServer(engine)
    server.open()
    return server.start()


@pytest.fixture
def served(sim):
    """``(sim, server)``: ``sim`` served on 127.0.0.1 (emScon port and control port)."""
    server = _serve(sim)
    yield sim, server
    server.stop()


@pytest.fixture
def exact_served(exact_sim):
    server = _serve(exact_sim)
    yield exact_sim, server
    server.stop()


@pytest.fixture
def tracker(served):
    """``(sim, tracker)``: a connected adapter with short deadlines."""
    sim, server = served
    trk = EmsconTracker(
        "127.0.0.1",
        server.port,
        environment=ENV,
        timeout_s=1.0,
        measure_timeout_s=1.0,
        search_timeout_s=1.0,
        reconnect_delay_s=0.01,
    )
    trk.connect()
    yield sim, trk
    trk.close()
