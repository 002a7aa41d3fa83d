"""The simulated cell with the emScon simulator (``--tracker emscon+sim``): the simulated arm
steers it as it steers the line simulator, and ``verify --path`` runs end to end through it.

The emScon simulator process is the same simulated tracker as the line
simulator's (:mod:`drivers.tracker.instrument`): the arm's true probe reaches
it over the control port (``SIM,TARGET`` after a move, ``SIM,PATH`` for a
timed path), and the reading comes back over the emScon wire. With exact
readings the path test's figures must be the line simulator's for the same
seed; with noise, close to them. Each call that runs a procedure is bounded
by ``within`` (the simulator processes are stopped by their drivers' ``close``).
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_kit import cli
from timeout_kit import within

from calibrator import robots
from calibrator.acquire import ports
from drivers.devices import Devices, is_sim
from drivers.tracker import open_tracker
from drivers.tracker.base import OpenOptions

SEED = "3"
PATH = ("--path", "circle", "--cycles", "2", "--path-speed", "400")
#: Longest one verify --path run may take here, s (about 15 s on an idle machine).
RUN_S = 240.0


def _verify(folder, tracker: str, name: str) -> dict:
    args = ("verify", "--seed", SEED, *PATH, "--tracker", tracker, "-o", name)
    done = within(lambda: cli(*args, cwd=folder), RUN_S, f"verify --tracker {tracker}")
    assert done.code == 0, done.stderr
    assert "AT_P" in done.stdout
    return json.loads((folder / name).read_text())["path"]


def test_the_kind_is_opened_by_url_and_refuses_what_it_cannot_do():
    assert is_sim("emscon+sim") and is_sim("emscon+sim://?noise=off") and not is_sim("emscon://h")
    with pytest.raises(ValueError, match="needs the simulated world"):
        open_tracker("emscon+sim")
    with pytest.raises(ValueError, match="replay"):
        open_tracker("emscon+sim://?replay=x.log", OpenOptions(world=object()))  # type: ignore[arg-type]


def test_the_simulated_arm_steers_the_emscon_simulator_after_each_move():
    arm = robots.get("ur10e")
    opened = Devices("sim", "emscon+sim://?noise=off").open(arm, 3, None, None)
    robot, tracker = opened.robot, opened.tracker
    try:
        assert ports.FOLLOW_PATH.offered_by(robot)  # its timed paths run on the simulator
        within(robot.connect, 60.0, "the simulated arm")
        status = within(tracker.connect, 60.0, "the emScon simulator")
        assert status.initialised and tracker.device_id == "emscon:serial=390001"
        q = robot.actual_joints() + np.radians([10.0, -5.0, 5.0, 0.0, 10.0, 0.0])
        robot.move_joints(q, 0.5, 1.0)
        # The emScon reading is the arm's true probe (exact readings), in the tracker frame.
        np.testing.assert_allclose(
            tracker.measure().point_mm, robot.true_tool_pose()[:3, 3], atol=1e-6
        )
    finally:
        tracker.close()
        robot.close()


def test_verify_path_through_the_emscon_simulator_gives_the_line_simulators_figures(tmp_path):
    emscon = _verify(tmp_path, "emscon+sim://?noise=off", "e.json")
    line = _verify(tmp_path, "sim://?noise=off", "l.json")
    assert emscon["commanded"] == line["commanded"]
    # Exact readings of the same true arm on the same path: the same deviations, to the
    # micrometre (the two wires round differently, far below it).
    assert emscon["AT_P_mm"] == pytest.approx(line["AT_P_mm"], abs=1e-3)
    assert emscon["AT_P_mm"] > 0.5  # the hidden errors of seed 3 stray the circle
    np.testing.assert_allclose(emscon["points"]["AT_mm"], line["points"]["AT_mm"], atol=1e-3)
    # Each cycle's ticks fall at another phase of the path (the stream starts after four
    # round trips on emScon): 2 ms ticks at 400 mm/s are 0.8 mm apart, and a chord of the
    # 146 mm circle strays 0.55 um from its arc, so the cycles differ by about a micrometre.
    assert emscon["RT_P_mm"] < 3e-3 and abs(emscon["AV_pct"] - line["AV_pct"]) < 0.01
    # With the tracker's noise (the default), AT_P stays within its tens of micrometres.
    noisy = _verify(tmp_path, "emscon+sim", "n.json")
    assert noisy["AT_P_mm"] == pytest.approx(line["AT_P_mm"], abs=0.03)
    assert 1e-3 < noisy["RT_P_mm"] < 0.05
