"""Measuring conditions: the tracker's COND?, the arm's joint temperatures, kept per pose."""

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_kit import cli

from calibrator import robots, session
from calibrator.acquire import warmup
from calibrator.errors import SessionError
from calibrator.model import kinematics
from drivers.robot.sim.device import SimulatedRobot
from drivers.robot.ur.simulator.controller import JOINT_RISE_C, ROOM_C, WARM_TAU_S, FakeController
from drivers.tracker.line.device import LaserTracker
from drivers.tracker.line.simulator.launch import SimulatorProcess

FIXTURE = Path(__file__).parents[2] / "fixtures" / "measure" / "session.parquet"
COLD = "world: 1\nseed: 3\ntracker: {air: [23.5, 990, 35], on_minutes: 20}\n"


def test_cond_reports_the_air_the_time_on_and_the_warm_up_over_the_wire():
    with SimulatorProcess(initialised=True, air=(21.5, 990.0, 40.0), on_s=600.0) as sim:
        tracker = LaserTracker(sim.url)
        tracker.connect()
        try:
            said = tracker.conditions()
        finally:
            tracker.close()
    assert said["air_temperature_c"] == 21.5 and said["air_pressure_hpa"] == 990.0
    assert said["air_humidity_pct"] == 40.0 and said["warmed_up"] is False
    assert 600.0 <= said["on_s"] < 660.0
    with SimulatorProcess(initialised=True) as sim:  # the default: on for 3 h
        tracker = LaserTracker(sim.url)
        tracker.connect()
        try:
            assert tracker.conditions()["warmed_up"] is True
        finally:
            tracker.close()


def test_measure_with_a_cold_tracker_warns_and_the_session_keeps_the_conditions(tmp_path):
    (tmp_path / "cold.yaml").write_text(COLD)
    done = cli(
        "measure", "--model", "ur10e", "--world", "cold.yaml", "--poses", "30", "-o", "s.parquet",
        "-q", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    assert "warning: the tracker says it has not warmed up (on for 20 min)" in done.stderr
    loaded = session.load(tmp_path / "s.parquet")
    said = loaded.conditions()
    assert said["air_temperature_c"] == {"min": 23.5, "mean": 23.5, "max": 23.5}
    assert said["air_pressure_hpa"]["mean"] == 990.0 and said["air_humidity_pct"]["max"] == 35.0
    assert 1200.0 <= said["tracker_on_s"]["min"] <= said["tracker_on_s"]["max"] < 1260.0
    assert said["tracker_warmed_up"] is False and said["poses_reporting"] == 30
    table = pq.read_table(tmp_path / "s.parquet")
    assert table["tracker_warmed_up"].to_pylist() == [False] * 30
    # The report shows them.
    assert cli("identify", "s.parquet", "-o", "c.json", "-q", cwd=tmp_path).code == 0
    assert cli("report", "c.json", "s.parquet", "-o", "r", cwd=tmp_path).code == 0
    page = (tmp_path / "r" / "index.html").read_text()
    assert "air at the tracker</th><td>23.5 °C, 990.0 hPa, 35 %RH</td>" in page
    assert "tracker warm-up</th><td>NOT warmed up, on for 20 min</td>" in page


def test_a_warm_tracker_gives_no_warning(tmp_path):
    done = cli("measure", "--model", "ur10e", "--poses", "30", "-o", "s.parquet", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "warm" not in done.stderr
    assert session.load(tmp_path / "s.parquet").conditions()["tracker_warmed_up"] is True


def test_warm_up_is_refused_for_the_external_robot(tmp_path):
    result = cli(
        "measure", "--robot", "external", "--warm-up", "5", "-o", "s.parquet", cwd=tmp_path
    )
    assert result.code == 2


def test_sessions_without_conditions_read_as_before_and_bad_ones_are_refused(tmp_path):
    old = session.load(FIXTURE)  # written before the condition columns existed
    assert old.conditions() == {}
    n = len(old.table)
    rows = [{"air_temperature_c": 20.0, "joint_temperatures_c": [30, 31, 32, 33, 34, 35]}]
    rows += [{}] * (n - 1)
    with_some = session.to_table(
        old.array(session.JOINT_COLUMNS), old.array(session.POINT_COLUMNS), conditions=rows
    )
    assert with_some["j2_temperature_c"].to_pylist() == [31.0] + [None] * (n - 1)
    session.write(tmp_path / "some.parquet", with_some, old.meta)
    said = session.load(tmp_path / "some.parquet").conditions()
    assert said["j6_temperature_c"]["max"] == 35.0 and said["poses_reporting"] == 1
    column = with_some.column_names.index("air_temperature_c")
    bad = with_some.set_column(
        column, "air_temperature_c", pa.array([float("nan")] + [None] * (n - 1), pa.float64())
    )
    session.write(tmp_path / "bad.parquet", bad, old.meta)
    with pytest.raises(SessionError, match="air_temperature_c has NaN or infinite"):
        session.load(tmp_path / "bad.parquet")


def test_the_fake_ur_reports_joints_warming_from_the_room():
    fake = FakeController()
    fake.frozen_timestamp = 0.0
    np.testing.assert_allclose(fake.snapshot()["joint_temperatures"], ROOM_C)
    fake.frozen_timestamp = WARM_TAU_S
    temps = np.array(fake.snapshot()["joint_temperatures"])
    np.testing.assert_allclose(temps, ROOM_C + JOINT_RISE_C * (1 - np.exp(-1)))


def test_warm_up_runs_the_checked_path_forwards_then_backwards():
    mdh = robots.get("ur10e").mdh
    poses = []
    robot = SimulatedRobot(mdh, np.eye(4), np.eye(4), listener=poses.append)
    robot.connect()
    path = np.linspace(0.0, 0.5, 4)[:, None] * np.ones(6)
    assert warmup.warm_up(robot, path, 3, 0.5, 1.0) == 12
    order = [0, 1, 2, 3, 3, 2, 1, 0, 0, 1, 2, 3]  # no jump from the last row to the first
    expected = kinematics.forward(mdh, path[order], np.eye(4))
    np.testing.assert_allclose(np.array(poses), expected, atol=1e-9)
    stop_after = iter([False, False, True])
    assert warmup.warm_up(robot, path, 3, 0.5, 1.0, lambda: next(stop_after)) == 2
    assert warmup.passes_for(10, 120.0) == 5 and warmup.passes_for(0.1, 120.0) == 1
    assert warmup.passes_for(0, 120.0) == 0


def test_emscon_reports_its_environment_parameters():
    from drivers.tracker.base import Environment
    from drivers.tracker.emscon import EmsconTracker
    from drivers.tracker.emscon.simulator import EmsconServer, EmsconSimulator

    server = EmsconServer(EmsconSimulator(seed=1, initialised=True))
    server.open()
    server = server.start()
    try:
        tracker = EmsconTracker(
            "127.0.0.1", server.port, environment=Environment(21.3, 1002.0, 45.0), timeout_s=1.0
        )
        tracker.connect()
        try:
            said = tracker.conditions()
        finally:
            tracker.close()
    finally:
        server.stop()
    assert said == pytest.approx(
        {"air_temperature_c": 21.3, "air_pressure_hpa": 1002.0, "air_humidity_pct": 45.0}
    )


def test_a_recording_with_cond_queries_replays_to_the_same_session(tmp_path):
    from drivers.tracker import read_log

    common = ("measure", "--poses", "30", "--readings", "3")
    done = cli(
        *common,
        "--tracker",
        "sim://?noise=off&record=rec.jsonl",
        "-o",
        "a.parquet",
        "-q",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    sent = [e.data for e in read_log(tmp_path / "rec.jsonl") if e.direction == "tx"]
    assert sum(b",COND?*" in line for line in sent) == 31  # the warm-up check, then each pose
    done = cli(
        *common,
        "--tracker",
        "sim://?noise=off&replay=rec.jsonl",
        "-o",
        "b.parquet",
        "-q",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    a, b = (pq.read_table(tmp_path / f"{n}.parquet").to_pydict() for n in "ab")
    for column in ("pose", "q1_rad", "x_mm", "y_mm", "z_mm"):
        assert a[column] == b[column], column
    assert "air_temperature_c" in a and "air_temperature_c" not in b  # a replay does not ask
