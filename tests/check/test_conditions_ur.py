"""A UR arm's joint temperatures (RTDE ``joint_temperatures``) reach the session.

The real ur-rtde client against the fake controller process (fixed ports,
as tests/acquire/test_measure_ur.py); the tracker simulator follows the joints.
"""

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_process_kit import run_cli

from drivers.robot.ur.simulator.controller import JOINT_RISE_C, ROOM_C
from drivers.robot.ur.simulator.launcher import FakeUrProcess

pytest.importorskip("rtde_receive")


def test_measure_keeps_the_joint_temperatures_the_controller_reports(tmp_path):
    with FakeUrProcess(time_scale=50.0, model="ur10e", unlock_delay_s=0.5):
        done = run_cli(
            "measure", "--robot", "ur://127.0.0.1", "--poses", "12", "--tracker", "sim://?noise=off",
            "--speed", "1.0", "--accel", "2.0", "--settle", "0", "--yes", "-o", "s.parquet",
            cwd=tmp_path,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr
    table = pq.read_table(tmp_path / "s.parquet")
    temps = np.array([table[f"j{j}_temperature_c"].to_pylist() for j in range(1, 7)]).T
    assert temps.shape == (12, 6)
    assert np.all(temps >= ROOM_C) and np.all(temps <= ROOM_C + JOINT_RISE_C)
    assert np.all(np.diff(temps, axis=0) >= 0)  # warming while it runs, never cooling
    assert temps[-1, 1] > temps[0, 1]
