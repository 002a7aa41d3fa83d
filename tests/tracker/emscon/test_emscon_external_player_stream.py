"""The external-robot player steering the emScon simulator process while the emScon driver
streams it: the player's targets reach the simulator over its control port (the line
simulator's ``SIM,TARGET``), and the continuous stream shows the arm moving, each point
one the player sent, never one from another time.

Bounded: the player runs in a thread joined with a timeout, the stream by its count and
stall timeout, the simulator process by its helper's stop.
"""

from __future__ import annotations

import threading

import numpy as np

from drivers.robot.external_sim.player import Player, PlayerOptions
from drivers.tracker.emscon import open_tracker
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess
from drivers.tracker.line.simulator.launch import SimulatorControl

PLAN = np.array(
    [[0.0, -1.2, 1.4, -1.8, -1.57, 0.0], [0.4, -1.0, 1.2, -1.7, -1.4, 0.3]]
)  # two poses of a UR10e, 0.4 rad apart at most
FIRST = np.array([2000.0, 0.0, 0.0])  # the target before the program starts, mm


def test_the_player_moves_the_emscon_simulators_target_and_the_stream_sees_each_step():
    options = PlayerOptions(speed_rad_s=1.0, accel_rad_s2=4.0, dwell_s=0.3, tick_s=0.02)
    player = Player.for_model(PLAN, "ur10e", 3, options)
    sent: list[np.ndarray] = []
    with EmsconSimulatorProcess(seed=4, noise=False, initialised=True) as sim:
        control = SimulatorControl(sim.control_url)
        tracker = open_tracker(sim.url, timeout_s=2.0, measure_timeout_s=2.0)
        try:
            tracker.connect()

            def send(point_mm: np.ndarray) -> None:
                control.set_target(point_mm)
                sent.append(np.round(np.asarray(point_mm, float), 6))  # as SIM,TARGET sends

            control.set_target(FIRST)  # something to lock on before the program starts
            play = threading.Thread(target=player.play, args=(send,), daemon=True)
            with tracker.stream(50, stall_timeout_s=2.0) as stream:
                play.start()
                rec = stream.collect(120)  # 2.4 s at 50 Hz: the whole program
            play.join(timeout=30.0)
            assert not play.is_alive(), "the player did not finish"
        finally:
            tracker.close()
            control.close()
    targets = np.array(sent)
    assert len(targets) > 20
    got = rec.code == 0
    assert got.all() and (stream.lost, stream.stale) == (0, 0)
    points = rec.point_mm[got]
    moved = points[np.linalg.norm(points - FIRST, axis=1) > 1e-6]
    assert len(moved) > 50
    # Every streamed point once the program runs is one the player sent: the target is
    # held between SIM,TARGETs, never invented, never from another time ...
    near = np.linalg.norm(moved[:, None, :] - targets[None, :, :], axis=2) < 1e-5
    assert near.any(axis=1).all()
    # ... and the points come in the order they were sent (the program returns home at
    # its end, so a point may match several sends: take the earliest not before the last).
    at = 0
    for row in near:
        later = np.flatnonzero(row[at:])
        assert later.size, "a point the player sent before the previous one"
        at += int(later[0])
    # The stream followed the arm through the program, not one held position.
    assert np.ptp(moved, axis=0).max() > 0.5 * np.ptp(targets, axis=0).max() > 50.0
