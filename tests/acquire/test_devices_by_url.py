"""Devices opened by URL in the drivers, and the measure run over them.

The robot and tracker are chosen by URL scheme from the drivers' registries
(``drivers.tracker.open_tracker``, ``drivers.robot.open_robot``): ``sim`` (the
simulated arm and the tracker simulator behind a pty), a device path or a
pyserial URL (the product's line protocol), ``emscon://HOST[:PORT]`` (a Leica
emScon server; its simulator here) and ``ur://HOST`` (built, never
connected: no controller runs in these tests). Each is checked by what it
measures, and a tracker kind registered from a test measures through the CLI.
"""

import re
import subprocess
import sys
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.acquire import ports
from calibrator.acquire.ports import ReadingLost, TrackerUnavailable
from calibrator.acquire.run import MeasureRun, RunOptions, tracker_position
from calibrator.errors import CalibrationError
from calibrator.model import DEFAULT_TOOL_MM, kinematics
from calibrator.simulate import (
    SIM_TRACKER_AT_MM,
    SIM_TRACKER_ROTVEC,
    SimWorld,
)
from drivers.devices import Devices
from drivers.registry import Registry, UnknownKind
from drivers.robot import RobotOptions, open_robot
from drivers.robot.errors import LimitsViolation
from drivers.robot.safety import GuardedRobot
from drivers.robot.sim.device import SimulatedRobot
from drivers.robot.sim.follow import Following, steer_tracker
from drivers.robot.ur.sim_cell import PathFollowing
from drivers.tracker import TRACKERS, LaserTracker, OpenOptions, open_tracker
from drivers.tracker.emscon import EmsconTracker
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess
from drivers.tracker.line.simulator import SimulatorProcess
from drivers.tracker.line.simulator.world import SimulatedTracker

UR10E = robots.get("ur10e")
Q = np.array([0.3, -1.2, 1.1, -0.4, 1.3, 0.2])


@pytest.mark.parametrize(
    ("url", "kind"),
    [
        ("sim", "sim"),
        ("/dev/ttyUSB0", "serial"),
        ("COM3", "serial"),
        ("socket://10.0.0.2:4000", "socket"),
        ("RFC2217://host:2217", "rfc2217"),
        ("loop://", "loop"),
        ("emscon://10.0.0.3:700?meteo=20,1013,45", "emscon"),
        ("ur://192.168.1.10", "ur"),
        ("simulated", "serial"),  # only the bare word means the simulated cell
    ],
)
def test_scheme_is_the_lowercase_part_before_the_separator(url, kind):
    from drivers.robot import ROBOTS

    registry = ROBOTS if kind == "ur" else TRACKERS
    assert registry.kind_of(url) == kind


def test_the_simulated_world_is_seeded_and_its_errors_are_small_but_real():
    world = SimWorld.make("ur10e", 4)
    again, other = SimWorld.make("ur10e", 4), SimWorld.make("ur10e", 5)
    np.testing.assert_array_equal(world.true_mdh, again.true_mdh)
    assert not np.allclose(world.true_mdh, other.true_mdh)
    delta = world.true_mdh - UR10E.mdh
    lengths, angles = delta[:, [0, 3]], delta[:, [1, 2, 4]]
    assert 0.05 < np.abs(lengths).max() <= 0.5 and 1e-4 < np.abs(angles).max() <= 1e-3
    offset = world.flange2tool[:3, 3] - DEFAULT_TOOL_MM
    assert np.linalg.norm(offset) == pytest.approx(1.5, abs=1e-12)
    np.testing.assert_allclose(world.flange2tool[:3, :3], np.eye(3), atol=0)
    tracker2base = np.linalg.inv(world.base2tracker)
    np.testing.assert_allclose(tracker2base[:3, 3], SIM_TRACKER_AT_MM, atol=1e-9)
    turn = Rotation.from_rotvec(SIM_TRACKER_ROTVEC).as_matrix()
    np.testing.assert_allclose(tracker2base[:3, :3], turn, atol=1e-12)
    assert world.model.name == "ur10e" and world.seed == 4


def test_the_worlds_tool_pose_is_the_true_arm_seen_from_the_tracker():
    world = SimWorld.make("ur10e", 1)
    base2flange = kinematics.chain(world.true_mdh, Q[None])[0]
    expected = world.base2tracker @ base2flange @ world.flange2tool
    np.testing.assert_allclose(world.tool_pose(list(Q)), expected, atol=1e-9)


def sim_run(tmp_path, tracker_url="sim", seed=3, noise=False, **options):
    """A run over the simulated cell opened by URL, and the cell's hidden truth (the test's)."""
    if tracker_url == "sim" and not noise:
        tracker_url = "sim://?noise=off"  # the simulator's settings are in its URL
    run_options = RunOptions(seed=seed, **options)
    opened = Devices("sim", tracker_url).open(
        UR10E, seed, tracker_position(run_options), ExitStack()
    )
    run = MeasureRun(
        opened.robot,
        opened.tracker,
        UR10E,
        run_options,
        tmp_path / "s.parquet",
        tracker_at_mm=opened.tracker_at_mm,
    )
    return run, SimWorld.make("ur10e", seed)


def measure_at(run, q):
    """Move the run's arm to ``q`` (rad) and take one reading: the point, mm."""
    run.robot.move_joints(q, 0.5, 1.0)  # the devices steer a simulated tracker themselves
    return run.tracker.measure().point_mm


def test_the_simulated_devices_satisfy_the_ports_and_measure_the_hidden_arm(tmp_path):
    run, world = sim_run(tmp_path)
    assert isinstance(run.tracker, SimulatedTracker) and isinstance(run.tracker, ports.Tracker)
    assert isinstance(run.robot, SimulatedRobot)
    assert ports.STEER in run.tracker.capabilities
    assert ports.REPORTS_TRUE_POSE in run.robot.capabilities and not run.moves_hardware
    with run:
        run.connect("sim")
        assert run.robot_id == "sim:ur10e:seed=3"
        assert run.tracker_id.startswith("CALIBRATOR:TRACKER-SIM")
        # The simulated arm itself steers the simulator: nothing wraps it.
        assert run.robot.listener is not None
        np.testing.assert_array_equal(run.tracker_at_mm, SIM_TRACKER_AT_MM)
        for q in (Q, -Q):
            np.testing.assert_allclose(measure_at(run, q), world.tool_pose(q)[:3, 3], atol=1e-4)
        tracker = run.tracker
    with pytest.raises(OSError):  # closing the run closed the link and the simulator
        tracker.measure()


def test_the_simulator_is_noisy_unless_told_otherwise(tmp_path):
    run, world = sim_run(tmp_path, noise=True)
    with run:
        run.connect()
        run.robot.move_joints(Q, 0.5, 1.0)
        points = np.array([run.tracker.measure().point_mm for _ in range(3)])
    assert np.all(np.ptp(points, axis=0) > 0)  # no two readings alike
    np.testing.assert_allclose(points, np.tile(world.tool_pose(Q)[:3, 3], (3, 1)), atol=0.2)


def test_a_given_tracker_position_overrides_the_simulated_one(tmp_path):
    run, _ = sim_run(tmp_path, tracker_at_mm=(1, 2, 3))
    assert run.tracker_at_mm.dtype == float
    np.testing.assert_array_equal(run.tracker_at_mm, [1.0, 2.0, 3.0])


class PlainRobot(SimulatedRobot):
    """A simulated arm that does not report its true pose (as a real arm would not)."""

    capabilities = frozenset()


def test_a_robot_without_true_poses_places_the_simulated_target_after_each_move(tmp_path):
    world = SimWorld.make("ur10e", 2)
    plain = PlainRobot(world.true_mdh, world.base2tracker, world.flange2tool)
    plain.device_id = "plain"
    tracker = open_tracker("sim://?noise=off", OpenOptions(world=world))
    robot = steer_tracker(plain, tracker, world.tool_pose)
    assert isinstance(robot, Following) and robot.robot is plain
    assert robot.capabilities == plain.capabilities and robot.device_id == "plain"
    run = MeasureRun(robot, tracker, UR10E, RunOptions(), tmp_path / "s.parquet")
    with run:
        run.connect()
        np.testing.assert_allclose(measure_at(run, Q), world.tool_pose(Q)[:3, 3], atol=1e-4)
        np.testing.assert_allclose(measure_at(run, -Q), world.tool_pose(-Q)[:3, 3], atol=1e-4)
    with pytest.raises(TrackerUnavailable, match="^tracker simulator not started"):
        robot.after_move(Q)  # the simulator has been stopped with the run


def test_a_real_arms_driver_is_wrapped_to_steer_the_simulated_tracker_and_keeps_its_caps():
    # ur:// is only built here (never connected), nor is the simulated tracker started.
    opened = Devices("ur://10.0.0.5", "sim").open(UR10E, 1, None, ExitStack())
    robot = opened.robot
    # The UR's moves steer the tracker (Following); its timed paths run on the
    # tracker's target too (PathFollowing, the path test's FOLLOW_PATH).
    assert isinstance(robot, PathFollowing) and isinstance(robot.robot, Following)
    assert isinstance(robot.robot.robot, GuardedRobot)
    assert {ports.MOVES_HARDWARE, ports.CHECKS_PLAN, ports.FOLLOW_PATH} <= robot.capabilities
    assert ports.CHECKS_PLAN.offered_by(robot) and robot.device_id == "ur://10.0.0.5:ur10e"
    with pytest.raises(LimitsViolation, match="joint J1: 9 rad outside"):
        robot.check_plan(np.full((1, 6), 9.0), 0.5, 1.0)  # the inner robot's own check
    np.testing.assert_array_equal(opened.tracker_at_mm, SIM_TRACKER_AT_MM)
    # Real devices: no simulated cell behind them, nothing known of it.
    real = Devices("ur://10.0.0.5", "emscon://10.0.0.7").open(UR10E, 1, None, ExitStack())
    assert isinstance(real.robot, GuardedRobot)
    assert real.tracker_at_mm is None and real.surveyed_base2tracker is None


@pytest.mark.parametrize("endpoint", ["url", "control_url"], ids=["pty", "socket"])
def test_a_line_protocol_tracker_by_device_path_or_socket_url(endpoint):
    with SimulatorProcess(noise=False, initialised=True) as sim:
        url = getattr(sim, endpoint)
        tracker = open_tracker(url)
        assert type(tracker) is LaserTracker and isinstance(tracker, ports.Tracker)
        try:
            assert tracker.connect().initialised
            assert tracker.device_id.startswith("CALIBRATOR:")
            sim.set_target([1000.0, -20.5, 300.25])
            np.testing.assert_allclose(tracker.measure().point_mm, [1000.0, -20.5, 300.25])
        finally:
            tracker.close()


@pytest.mark.parametrize(
    "simulator", [SimulatorProcess, EmsconSimulatorProcess], ids=["line", "emscon"]
)
def test_an_uninitialised_tracker_is_refused_and_never_initialised(simulator, tmp_path):
    with simulator(noise=False, initialised=False) as sim:
        world = SimWorld.make("ur10e", 0)
        run = MeasureRun(
            open_robot("sim", RobotOptions(UR10E, world)),
            open_tracker(sim.url),
            UR10E,
            RunOptions(),
            tmp_path / "s.parquet",
        )
        with run, pytest.raises(CalibrationError) as exc:
            run.connect(sim.url)
        assert str(exc.value) == (
            f"tracker at {sim.url} is not initialised: run `calibrator tracker init "
            f"--tracker {sim.url}` (it moves the head), then measure again"
        )
        with open_tracker(sim.url) as again:  # the run's driver is closed with the run
            assert not again.connect().initialised  # nobody initialised it


def test_an_unreachable_tracker_is_refused_in_one_line(tmp_path):
    run, _ = sim_run(tmp_path, tracker_url="socket://127.0.0.1:1")
    with run, pytest.raises(CalibrationError, match="^tracker at socket://127.0.0.1:1: "):
        run.connect("socket://127.0.0.1:1")


def test_a_hang_up_is_a_lost_reading_a_dead_tracker_is_unavailable():
    # The TCP endpoint survives a hang-up (a pty's number could be reused meanwhile).
    with SimulatorProcess(noise=False, initialised=True) as sim:
        sim.set_target([1000.0, -20.5, 300.25])
        tracker = open_tracker(sim.control_url)
        try:
            tracker.connect()
            sim.arm_fault("MEAS+1 hangup")
            with pytest.raises(ReadingLost, match="reconnected, command not repeated"):
                tracker.measure()
            np.testing.assert_allclose(tracker.measure().point_mm, [1000.0, -20.5, 300.25])
            sim.stop()
            with pytest.raises(TrackerUnavailable, match="reconnect attempts failed"):
                tracker.measure()
        finally:
            tracker.close()


def test_a_ur_robot_is_guarded_by_the_models_limits_and_the_users_caps():
    options = RobotOptions(UR10E, max_speed_rad_s=0.7, max_accel_rad_s2=1.5)
    robot = open_robot("ur://10.0.0.5/", options)  # built, not connected
    assert isinstance(robot, GuardedRobot) and robot.robot.host == "10.0.0.5"
    assert {ports.MOVES_HARDWARE, ports.CHECKS_PLAN} <= robot.capabilities
    limits = robot.limits
    assert (limits.max_speed_rad_s, limits.max_accel_rad_s2) == (0.7, 1.5)
    np.testing.assert_array_equal(limits.joint_limits_rad, UR10E.joint_limits_rad)
    np.testing.assert_array_equal(limits.max_joint_speed_rad_s, UR10E.max_joint_speed_rad_s)
    assert robot.device_id == "ur://10.0.0.5:ur10e"
    with pytest.raises(ValueError) as exc:
        open_robot("ur:///", options)
    assert str(exc.value) == "'ur:///': missing host (use ur://HOST)"
    assert open_robot("ur://Xarm.local", options).device_id == "ur://Xarm.local:ur10e"


def test_unknown_schemes_are_refused_naming_the_known_ones():
    known = "use sim or ur://HOST or external"
    with pytest.raises(ValueError, match=f"^unknown robot 'kuka://x'; {known}$"):
        open_robot("kuka://x", RobotOptions(UR10E))
    with pytest.raises(UnknownKind, match="^unknown tracker 'ftp://x'; use sim or a device path"):
        open_tracker("ftp://x")
    with pytest.raises(UnknownKind, match="^unknown robot 'kuka'; use sim or ur://HOST or"):
        open_robot("kuka", RobotOptions(UR10E))


def test_a_registry_opens_a_module_handler_a_named_function_or_a_callable():
    registry: Registry = Registry("gadget", bare=("sim",), bare_default="serial")
    registry.register("sim", "drivers.tracker.line.simulator.world")
    registry.register("emscon", "drivers.tracker.emscon.device:open_url")
    registry.register("echo", lambda url, options: (url, options), usage="echo://ANY")
    assert registry.kinds() == ["sim", "emscon", "echo"]
    assert registry.open("ECHO://x", 7) == ("ECHO://x", 7)
    assert isinstance(registry.open("emscon://h", OpenOptions()), EmsconTracker)
    with pytest.raises(ValueError, match="needs the simulated world"):
        registry.open("sim", OpenOptions())  # the module's open_url refused it
    with pytest.raises(UnknownKind) as err:
        registry.open("/dev/ttyUSB0", None)  # a bare path is serial: not registered here
    assert str(err.value) == ("unknown gadget '/dev/ttyUSB0'; use sim or emscon:// or echo://ANY")
    # What the CLI already maps to one line: a ValueError, and a driver error.
    assert isinstance(err.value, ValueError) and isinstance(err.value, OSError)


def test_an_emscon_tracker_with_meteo_measures_the_arm_the_simulated_robot_steers(tmp_path):
    with EmsconSimulatorProcess(noise=False, initialised=True) as sim:
        url = sim.url + "?meteo=21.5,1000,40"
        world = SimWorld.make("ur10e", 1)
        tracker = open_tracker(url)
        assert isinstance(tracker, EmsconTracker) and isinstance(tracker, ports.Tracker)
        # The simulated arm steers the simulator started by hand through its control port.
        robot = open_robot(f"sim://?control={sim.control_url}", RobotOptions(UR10E, world))
        run = MeasureRun(robot, tracker, UR10E, RunOptions(), tmp_path / "s.parquet")
        with run:
            run.connect(url)
            assert re.fullmatch(r"emscon:serial=\d+", run.tracker_id)
            np.testing.assert_allclose(measure_at(run, Q), world.tool_pose(Q)[:3, 3], atol=1e-3)
            np.testing.assert_allclose(run.tracker.measure().meteo, (21.5, 1000.0, 40.0))


@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("emscon://", "^'emscon://': missing host"),
        ("emscon://h?meteo=1,2", "^'emscon://h.meteo=1,2': meteo needs T,P,H"),
    ],
)
def test_bad_emscon_urls_are_refused(url, message):
    with pytest.raises(ValueError, match=message):
        open_tracker(url)


# ------------------------------------------------- a third tracker kind, from a test

FAKE_KIND = '''
import sys
import numpy as np
from calibrator.acquire import ports
from calibrator.acquire.averaging import measure_average  # noqa: F401  (the port's user)
from drivers.tracker import register_tracker


class Status:
    initialised = True


class Reading:
    def __init__(self, point):
        self.point_mm = point
        self.rotvec_rad = None
        self.accurate = True
        self.device_time_us = 0


class FakeTracker:
    """Reads a fixed point plus a per-reading offset; satisfies the port directly."""

    capabilities = frozenset()
    device_id = "fake:1"

    def __init__(self, url, options):
        self.n = 0

    def connect(self):
        return Status()

    def status(self):
        return Status()

    def measure(self, timeout_s=None):
        self.n += 1
        return Reading(np.array([1000.0, 2.0, 3.0]) + 1e-3 * (self.n % 2))

    def close(self):
        pass


register_tracker("fake", FakeTracker)
from calibrator.cli import main

main(sys.argv[1:])
'''


def test_a_tracker_kind_registered_from_outside_measures_through_the_unchanged_cli(tmp_path):
    out = tmp_path / "s.parquet"
    done = subprocess.run(
        [sys.executable, "-c", FAKE_KIND, "measure", "--tracker", "fake://bench",
         "--poses", "12", "--readings", "4", "-q", "-o", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"wrote {out}: 12 poses x 4 readings"
    table = pq.read_table(out).to_pydict()
    assert table["pose"] == list(range(12))
    np.testing.assert_allclose(table["x_mm"], 1000.0005, atol=1e-9)
    meta = pq.read_schema(out).metadata[b"calibrator"].decode()
    assert '"tracker": "fake:1"' in meta


def test_one_noise_model_for_synthetic_sessions_and_both_tracker_simulators():
    from calibrator import simulate
    from calibrator.model import noise
    from drivers.tracker.emscon.simulator import EmsconSimulator
    from drivers.tracker.instrument import NoiseModel
    from drivers.tracker.line.simulator import TrackerSimulator

    # Both simulators are front-ends of one instrument, whose noise is the world's model.
    assert NoiseModel is noise.NoiseModel
    assert type(TrackerSimulator().noise) is type(EmsconSimulator().noise) is noise.NoiseModel
    # A synthetic session's transverse noise grows with range as the model's does.
    point = np.array([[5000.0, 0.0, 0.0]])  # 5 m along x: y and z are transverse
    readings = simulate.tracker_readings(point, 20000, 1e-9, np.random.default_rng(1))[0]
    _, s_trans = noise.TRACKER_NOISE.sigmas_mm(point[0])
    growth = s_trans - noise.TRACKER_NOISE.transverse_mpe_um[0] / 2000.0  # per-metre part
    np.testing.assert_allclose(readings[:, 1:].std(axis=0), growth, rtol=0.03)
    assert readings[:, 0].std() < 1e-8  # along the beam: the session's own sigma


# ------------------------------------------------- simulators configured by their URL


def test_the_simulators_take_their_settings_from_their_urls():
    world = SimWorld.make("ur10e", 1)
    exact = open_tracker("sim://?noise=off&probe=6dof", OpenOptions(world=world))
    assert isinstance(exact, SimulatedTracker)
    assert (exact._noise, exact._probe_6dof) == (False, True)
    bare = open_tracker("sim", OpenOptions(world=world))
    assert (bare._noise, bare._probe_6dof, bare._faults) == (True, False, None)
    with pytest.raises(ValueError, match="noise='maybe' is not one of on, off"):
        open_tracker("sim://?noise=maybe", OpenOptions(world=world))
    with pytest.raises(ValueError, match="unknown parameter 'colour'"):
        open_robot("sim://?colour=red", RobotOptions(UR10E, world))

    def landing_error_mm(url):
        robot = open_robot(url, RobotOptions(UR10E, world))
        robot.connect()
        robot.move_joints(Q, 0.5, 1.0)
        return np.linalg.norm(robot.true_tool_pose()[:3, 3] - world.tool_pose(Q)[:3, 3])

    assert world.repeatability is None
    assert 0.0 < landing_error_mm("sim://?repeatability=typical") < 0.2
    assert landing_error_mm("sim") < 1e-9


def test_the_cli_writes_the_world_file_and_verify_default_into_the_urls(tmp_path):
    from calibrator.cli import _run
    from calibrator.world import parse_world

    quiet_world = parse_world({"world": 1, "noise": False, "repeatability": True})
    robot, tracker = _run.device_urls("sim", "sim", world_file=quiet_world)
    assert (robot, tracker) == ("sim://?repeatability=typical", "sim://?noise=off")
    world = SimWorld.make("ur10e", 1)
    assert not open_tracker(tracker, OpenOptions(world=world))._noise
    # A typed URL keeps its own settings (never a setting twice); nothing said leaves it alone.
    assert _run.device_urls(
        "sim://?repeatability=none", "sim://?noise=on", world_file=quiet_world
    ) == ("sim://?repeatability=none", "sim://?noise=on")
    assert _run.device_urls("sim", "sim://?probe=6dof", repeatability=True) == (
        "sim://?repeatability=typical",
        "sim://?probe=6dof",
    )
    assert _run.device_urls("ur://h", "socket://h:1", world_file=quiet_world) == (
        "ur://h",
        "socket://h:1",
    )


def test_the_simulated_tracker_url_names_its_files(tmp_path):
    from calibrator.cli import _run
    from drivers.devices import recorded

    faults = tmp_path / "faults.txt"
    faults.write_text("MEAS@1 beam_break\n")
    url = f"sim://?noise=off&faults={faults}&record={tmp_path / 'rec.jsonl'}"
    assert _run.sim_files(url) == ([faults], tmp_path / "rec.jsonl")
    # The record is the devices' to open: the simulator is handed the rest.
    assert recorded(url) == (f"sim://?noise=off&faults={faults}", tmp_path / "rec.jsonl")
    assert recorded("sim://?record=r.jsonl") == ("sim://", Path("r.jsonl"))
    assert recorded("socket://h:1") == ("socket://h:1", None)
    opened = open_tracker(recorded(url)[0], OpenOptions(world=SimWorld.make("ur10e", 1)))
    assert opened._faults == str(faults) and not opened._noise
