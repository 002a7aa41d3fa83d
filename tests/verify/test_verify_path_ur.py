"""``verify --path`` with a UR: its RTDE joint stream aligned in time with the tracker's.

The real ur-rtde client against the fake controller process (fixed ports:
``FakeUrProcess`` takes the machine-wide lock, one fake at a time), beside
the simulated tracker, which runs the true arm's probe along the path the
fake UR runs (drivers.robot.ur.sim_cell) and stamps its readings
``latency`` late (``sim://?latency=S``).
"""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pandas as pd
import pytest
from cli_process_kit import run_cli
from timeout_kit import within

from calibrator import robots
from calibrator.verify import path_procedure as path_test
from calibrator.verify import procedure as pose_test
from drivers.devices import Devices
from drivers.robot.ur.simulator.launcher import FakeUrProcess

#: Longest a 2-cycle path test on the fake UR may take here, s (about 30 s when idle).
TIMEOUT_S = 240.0
#: How close the tracker's latency is recovered, s. What limits it: the robot's stream
#: is sampled every 4 to 8 ms of a loaded host, and the fake arm steps to each servoJ
#: set-point, which the alignment's start and end see (measured: 0.1 to 1.7 ms short).
LATENCY_TOLERANCE_S = 0.004


@pytest.fixture(scope="module")
def fake():
    with FakeUrProcess(time_scale=10.0, model="ur10e") as process:
        yield process


@pytest.mark.parametrize("latency_s", [0.03, 0.08])
def test_a_tracker_latency_set_in_the_simulator_is_recovered_through_the_ur_path(
    fake, tmp_path, latency_s
):
    options = path_test.Options(
        "line", path_test.Speed(200.0), cycles=2, test=pose_test.Options(seed=3)
    )
    devices = Devices("ur://127.0.0.1", f"sim://?latency={latency_s}&noise=off")
    result = within(
        lambda: path_test.run(robots.get("ur10e"), options, tmp_path / "v.json", devices),
        TIMEOUT_S,
        "the path test",
    )
    section = result.document["path"]
    assert section["alignment"] == "robot stream"
    # The tracker's latency behind the arm, plus the arm's own lag behind its command
    # (the simulated tracker runs the true arm along the commanded timing): the latency set.
    found = np.add(section["latency_s"], section["start_s"])
    assert len(found) == 2
    np.testing.assert_allclose(found, latency_s, atol=LATENCY_TOLERANCE_S)
    # The arm's lag is a servo cycle or a few; the rest is the tracker's.
    assert all(0.0 <= s < 0.02 for s in section["start_s"])


def test_verify_path_on_the_fake_ur_end_to_end(fake, tmp_path):
    args = ("verify", "--robot", "ur://127.0.0.1", "--seed", "3", "--path", "rectangle")
    args += ("--cycles", "2", "--path-speed", "200", "-o", "r.json")
    refused = run_cli(*args, cwd=tmp_path, stdin=subprocess.DEVNULL, timeout=TIMEOUT_S)
    assert refused.returncode == 2 and "pass --yes" in refused.stderr, refused.stderr
    assert not list(tmp_path.iterdir())
    done = run_cli(*args, "--yes", cwd=tmp_path, timeout=TIMEOUT_S)
    assert done.returncode == 0, done.stderr
    doc = json.loads((tmp_path / "r.json").read_text())
    section = doc["path"]
    assert doc["robot"].startswith("ur://127.0.0.1") and section["shape"] == "rectangle"
    assert section["alignment"] == "robot stream" and len(section["latency_s"]) == 2
    # The default simulated tracker has no latency: what is found is the arm's lag, negated.
    found = np.add(section["latency_s"], section["start_s"])
    np.testing.assert_allclose(found, 0.0, atol=LATENCY_TOLERANCE_S)
    # The figures: the nominal arm's geometric error (as on the simulated arm), the
    # tracker's scatter, the speed programmed, the three corners.
    assert 0.2 < section["AT_P_mm"] < 3.0 and 0.0 < section["RT_P_mm"] < 0.2
    assert abs(section["AV_pct"]) < 1.0 and section["RV_pct"] < 1.0
    assert len(section["CR_mm"]) == len(section["CO_mm"]) == 3
    assert "AT_P" in done.stdout and "corners" in done.stdout
    table = pd.read_parquet(tmp_path / "r.parquet")
    assert set(table["cycle"]) == {1, 2} and table["t_s"].min() >= 0.0
    assert table["t_s"].max() <= section["commanded"]["length_mm"] / section["speed_mm_s"]


@pytest.mark.parametrize("latency", ["2", "-0.1", "soon"])
def test_a_simulated_tracker_latency_outside_0_to_1_s_is_refused_in_one_line(tmp_path, latency):
    done = run_cli(
        "verify", "--path", "line", "--tracker", f"sim://?latency={latency}", "-o", "v.json",
        cwd=tmp_path, timeout=TIMEOUT_S,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and f"latency='{latency}'" in lines[0], done.stderr
    assert not list(tmp_path.iterdir())


def test_an_emergency_stop_during_a_path_test_ends_it_with_exit_1_and_nothing_written(
    fake, tmp_path
):
    # Move 1 leads the arm to the path's start for cycle 1, move 2 for cycle 2: stopped there.
    assert fake.command("fake estop at movej 2") == "fake: estop at movej 2"
    args = ("verify", "--robot", "ur://127.0.0.1", "--seed", "3", "--path", "line")
    try:
        done = run_cli(
            *args, "--cycles", "2", "--yes", "-o", "v.json", cwd=tmp_path, timeout=TIMEOUT_S
        )
    finally:
        fake.command("fake estop at movej 0")
        fake.command("fake release estop")
        fake.command("power on")
        fake.command("brake release")
    assert done.returncode == 1, done.stderr
    ours = [line for line in done.stderr.splitlines() if "stopped:" in line]
    assert len(ours) == 1 and "emergency stop" in ours[0], done.stderr
    assert not list(tmp_path.iterdir())
