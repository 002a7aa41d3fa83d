"""The emScon simulator as its own process (``python -m drivers.tracker.emscon.simulator``),
steered like today's simulator: a simulated robot sets the target over the control port."""

from __future__ import annotations

import subprocess
import sys

import numpy as np

from drivers.robot.sim.device import SimulatedRobot
from drivers.tracker.emscon import open_tracker
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess


def test_simulated_robot_drives_the_emscon_simulator_process():
    base2tracker = np.eye(4)
    base2tracker[:3, 3] = [2500.0, 0.0, -400.0]  # robot base 2.5 m in front of the tracker
    flange2tool = np.eye(4)
    flange2tool[2, 3] = 50.0
    with EmsconSimulatorProcess(seed=3, noise=False, initialised=True) as sim:
        robot = SimulatedRobot.from_model(
            "ur5e",
            np.random.default_rng(5),
            base2tracker=base2tracker,
            flange2tool=flange2tool,
            listener=lambda pose: sim.set_target(pose[:3, 3]),  # as with SimulatorProcess
        )
        robot.connect()
        tracker = open_tracker(sim.url, timeout_s=2.0, measure_timeout_s=2.0)
        try:
            tracker.connect()
            rng = np.random.default_rng(8)
            for _ in range(3):
                robot.move_joints(rng.uniform(-1.0, 1.0, 6), 1.0, 1.0)
                reading = tracker.measure()
                truth = robot.true_tool_pose()[:3, 3]
                np.testing.assert_allclose(reading.point_mm, truth, atol=1e-5)
        finally:
            tracker.close()
            robot.close()


def test_entry_point_rejects_a_bad_fault_script_in_one_line(tmp_path):
    script = tmp_path / "faults.txt"
    script.write_text("MEAS@1 melt\n")
    proc = subprocess.run(
        [sys.executable, "-m", "drivers.tracker.emscon.simulator", "--faults", str(script)],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith("error: --faults:") and "melt" in proc.stderr
    assert "Traceback" not in proc.stderr
