"""The path test as a procedure: run from Python on devices opened by URL."""

from __future__ import annotations

import json
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from calibrator import robots
from calibrator.acquire import ports
from calibrator.errors import CalibrationError
from calibrator.verify import path_procedure as path_test
from calibrator.verify import procedure as pose_test
from drivers.devices import Devices

#: Longest a procedure may take here, s (a 2-cycle line at 400 mm/s takes about 5 s).
TIMEOUT_S = 180.0


def in_time(call, *args, **kwargs):
    """``call(*args, **kwargs)`` in a thread, failing the test if it takes over TIMEOUT_S."""
    pool = ThreadPoolExecutor(max_workers=1)
    try:
        return pool.submit(call, *args, **kwargs).result(timeout=TIMEOUT_S)
    finally:
        pool.shutdown(wait=False)


def test_the_path_test_runs_from_python_on_the_simulated_devices(tmp_path):
    arm = robots.get("ur10e")
    options = path_test.Options(
        "line", path_test.Speed(400.0), cycles=2, test=pose_test.Options(seed=3)
    )
    result = in_time(path_test.run, arm, options, tmp_path / "v.json", Devices())
    doc = json.loads((tmp_path / "v.json").read_text())
    assert doc == result.document and (tmp_path / "v.parquet").exists()
    assert doc["test"] == "path" and doc["path"]["shape"] == "line"
    # Who ran it comes from the devices: the simulated arm of seed 3.
    assert doc["robot"] == "sim:ur10e:seed=3"
    assert result.registration.method == "surveyed" and not result.compensated
    assert result.speed_mm_s == 400.0 and result.rated_mm_s > 0
    # The simulated arm is off its nominal model by tenths of a mm: the stream saw it.
    assert 0.05 < doc["path"]["AT_P_mm"] < 5.0
    assert set(np.unique(result.streams["cycle"])) == {1, 2}


def test_the_simulated_robot_follows_a_path_only_beside_the_simulated_tracker(tmp_path):
    arm = robots.get("ur10e")
    opened = Devices().open(arm, 3, None, None)
    try:
        assert ports.FOLLOW_PATH.offered_by(opened.robot)
    finally:
        opened.tracker.close()
    # A tracker reached by socket is no simulator to steer: no path following.
    opened = Devices("sim", "socket://127.0.0.1:9").open(arm, 3, None, None)
    assert not ports.FOLLOW_PATH.offered_by(opened.robot)


def test_devices_whose_robot_cannot_follow_a_path_are_refused_before_anything_connects(tmp_path):
    arm = robots.get("ur10e")
    devices = Devices("sim", "socket://127.0.0.1:9")  # nothing listens: a connect would fail
    options = path_test.Options("line", cycles=2, test=pose_test.Options(seed=3))
    with pytest.raises(CalibrationError, match="needs a robot that runs a timed path"):
        in_time(path_test.run, arm, options, tmp_path / "v.json", devices)
    assert not (tmp_path / "v.json").exists() and not (tmp_path / "v.parquet").exists()
