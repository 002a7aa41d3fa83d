"""What ``measure`` runs on (calibrator/cli/_hardware.py), built in-process from its URLs.

The robot and tracker are chosen by URL scheme: ``sim`` (the simulated arm
and the tracker simulator behind a pty), a device path or a pyserial URL
(the product's line protocol), ``emscon://HOST[:PORT][?meteo=T,P,H]`` (a
Leica emScon server; its simulator here) and ``ur://HOST`` (built, never
connected: no controller runs in these tests). Each rig is checked by what
it measures: the point the tracker reports for the pose the arm was sent to.
"""

import contextlib
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import kinematics
from calibrator.acquire.ports import ReadingLost, TrackerUnavailable
from calibrator.cli import _hardware as hw
from calibrator.errors import CalibrationError
from calibrator.models import get_model
from calibrator.simulate import DEFAULT_TOOL_POINT
from drivers.robot.safety import GuardedRobot
from drivers.robot.simulated import SimulatedRobot
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess
from drivers.tracker.simulator import SimulatorProcess

UR10E = get_model("ur10e")
Q = np.array([0.3, -1.2, 1.1, -0.4, 1.3, 0.2])
QUIET = hw.RigOptions(sim_noise=False)


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
    assert hw.scheme(url) == kind


def test_the_simulated_cell_is_seeded_and_its_errors_are_small_but_real():
    cell = hw.SimCell.make("ur10e", 4)
    again, other = hw.SimCell.make("ur10e", 4), hw.SimCell.make("ur10e", 5)
    np.testing.assert_array_equal(cell.true_mdh, again.true_mdh)
    assert not np.allclose(cell.true_mdh, other.true_mdh)
    delta = cell.true_mdh - UR10E.mdh
    lengths, angles = delta[:, [0, 3]], delta[:, [1, 2, 4]]
    assert 0.05 < np.abs(lengths).max() <= 0.5 and 1e-4 < np.abs(angles).max() <= 1e-3
    # The true tool point is 1.5 mm from the first guess; the tool is not turned.
    offset = cell.flange2tool[:3, 3] - DEFAULT_TOOL_POINT
    assert np.linalg.norm(offset) == pytest.approx(1.5, abs=1e-12)
    np.testing.assert_allclose(cell.flange2tool[:3, :3], np.eye(3), atol=0)
    # The tracker stands where the constants say, turned by their rotation vector.
    tracker2base = np.linalg.inv(cell.base2tracker)
    np.testing.assert_allclose(tracker2base[:3, 3], hw.SIM_TRACKER_AT_MM, atol=1e-9)
    turn = Rotation.from_rotvec(hw.SIM_TRACKER_ROTVEC).as_matrix()
    np.testing.assert_allclose(tracker2base[:3, :3], turn, atol=1e-12)
    assert cell.model.name == "ur10e"


def test_the_cells_tool_pose_is_the_true_arm_seen_from_the_tracker():
    cell = hw.SimCell.make("ur10e", 1)
    base2flange = kinematics.chain(cell.true_mdh, Q[None])[0]
    expected = cell.base2tracker @ base2flange @ cell.flange2tool
    np.testing.assert_allclose(cell.tool_pose(list(Q)), expected, atol=1e-9)


def measure_at(rig, q):
    """Move the rig's arm to ``q`` (rad) and take one reading: the point, mm."""
    actual = rig.robot.move_joints(q, 0.5, 1.0)
    if rig.after_move is not None:
        rig.after_move(actual)
    return rig.tracker.measure().point_mm


def test_the_simulated_rig_measures_the_hidden_arm():
    with contextlib.ExitStack() as stack:
        rig = hw.build("sim", "sim", hw.RigOptions(seed=3, sim_noise=False), stack)
        assert (rig.robot_id, rig.tracker_id) == ("sim:ur10e:seed=3", rig.tracker.identity)
        assert rig.tracker_id.startswith("CALIBRATOR:TRACKER-SIM")
        assert rig.real_robot is False and rig.after_move is None  # the robot steers the sim
        assert isinstance(rig.robot, SimulatedRobot) and rig.model.name == "ur10e"
        np.testing.assert_array_equal(rig.tracker_at_mm, hw.SIM_TRACKER_AT_MM)
        np.testing.assert_array_equal(rig.flange2tool_guess[:3, 3], DEFAULT_TOOL_POINT)
        truth = hw.SimCell.make("ur10e", 3)
        np.testing.assert_array_equal(rig.sim_cell.true_mdh, truth.true_mdh)
        for q in (Q, -Q):
            np.testing.assert_allclose(measure_at(rig, q), truth.tool_pose(q)[:3, 3], atol=1e-4)
        tracker = rig.tracker
    with pytest.raises(Exception):  # noqa: B017  the stack closed the tracker link
        tracker.measure()


def test_the_simulator_is_noisy_unless_told_otherwise():
    with contextlib.ExitStack() as stack:
        rig = hw.build("sim", "sim", hw.RigOptions(seed=3), stack)
        rig.robot.move_joints(Q, 0.5, 1.0)
        points = np.array([rig.tracker.measure().point_mm for _ in range(3)])
    truth = hw.SimCell.make("ur10e", 3).tool_pose(Q)[:3, 3]
    assert np.all(np.ptp(points, axis=0) > 0)  # no two readings alike
    np.testing.assert_allclose(points, np.tile(truth, (3, 1)), atol=0.2)


def test_a_given_tracker_position_overrides_the_simulated_one():
    with contextlib.ExitStack() as stack:
        rig = hw.build("sim", "sim", hw.RigOptions(tracker_at_mm=(1, 2, 3), sim_noise=False), stack)
        assert rig.tracker_at_mm.dtype == float
        np.testing.assert_array_equal(rig.tracker_at_mm, [1.0, 2.0, 3.0])


def test_a_robot_without_a_listener_places_the_target_after_each_move():
    """The path a real arm with the simulated tracker takes: ``after_move``."""
    with contextlib.ExitStack() as stack:
        rig = hw.Rig(model=UR10E, sim_cell=hw.SimCell.make("ur10e", 2))
        hw._sim_tracker("sim", rig, QUIET, stack)
        rig.tracker.connect()
        rig.after_move(Q)
        np.testing.assert_allclose(
            rig.tracker.measure().point_mm, rig.sim_cell.tool_pose(Q)[:3, 3], atol=1e-4
        )
        after_move = rig.after_move
    with pytest.raises(TrackerUnavailable, match="^tracker simulator: "):
        after_move(Q)  # the simulator has been stopped with the stack


@pytest.mark.parametrize("endpoint", ["url", "control_url"], ids=["pty", "socket"])
def test_a_line_protocol_tracker_by_device_path_or_socket_url(endpoint):
    with SimulatorProcess(noise=False, initialised=True) as sim, contextlib.ExitStack() as stack:
        url = getattr(sim, endpoint)
        rig = hw.build("sim", url, QUIET, stack)
        assert isinstance(rig.tracker, hw.LaserTrackerPort) and rig.tracker.url == url
        assert rig.tracker_id == rig.tracker.identity and rig.tracker_id.startswith("CALIBRATOR:")
        np.testing.assert_array_equal(rig.tracker_at_mm, hw.SIM_TRACKER_AT_MM)
        sim.set_target([1000.0, -20.5, 300.25])
        np.testing.assert_allclose(rig.tracker.measure().point_mm, [1000.0, -20.5, 300.25])


@pytest.mark.parametrize(
    ("simulator", "port_class", "init"),
    [
        (SimulatorProcess, hw.LaserTrackerPort, "INIT"),
        (EmsconSimulatorProcess, hw.EmsconPort, "it"),
    ],
    ids=["line", "emscon"],
)
def test_an_uninitialised_tracker_is_refused_and_never_initialised(simulator, port_class, init):
    with simulator(noise=False, initialised=False) as sim:
        port = port_class(sim.url)
        try:
            with pytest.raises(CalibrationError) as exc:
                port.connect()
            assert str(exc.value) == (
                f"tracker at {sim.url} is not initialised: initialise it first ({init} moves "
                "the head), then run measure again"
            )
            assert port.identity is None
        finally:
            port.close()


def test_an_unreachable_tracker_is_unavailable():
    port = hw.LaserTrackerPort("socket://127.0.0.1:1")
    with pytest.raises(TrackerUnavailable, match="^tracker at socket://127.0.0.1:1: "):
        port.connect()
    port.close()


def test_a_hang_up_is_a_lost_reading_a_dead_tracker_is_unavailable():
    # The TCP endpoint survives a hang-up (a pty's number could be reused meanwhile).
    with SimulatorProcess(noise=False, initialised=True) as sim:
        sim.set_target([1000.0, -20.5, 300.25])
        port = hw.LaserTrackerPort(sim.control_url)
        try:
            port.connect()
            sim.arm_fault("MEAS+1 hangup")
            with pytest.raises(ReadingLost, match="^link dropped and came back: "):
                port.measure()
            np.testing.assert_allclose(port.measure().point_mm, [1000.0, -20.5, 300.25])
            sim.stop()
            with pytest.raises(TrackerUnavailable, match=f"^tracker at {sim.control_url}: "):
                port.measure()
        finally:
            port.close()


def test_a_ur_robot_is_guarded_by_the_models_limits_and_the_users_caps():
    rig = hw.Rig(model=UR10E)
    options = hw.RigOptions(max_speed_rad_s=0.7, max_accel_rad_s2=1.5)
    hw._ur_robot("ur://10.0.0.5/", rig, options, None)  # built, not connected
    assert isinstance(rig.robot, GuardedRobot) and rig.robot.robot.host == "10.0.0.5"
    limits = rig.robot.limits
    assert (limits.max_speed_rad_s, limits.max_accel_rad_s2) == (0.7, 1.5)
    np.testing.assert_array_equal(limits.joint_limits_rad, UR10E.joint_limits_rad)
    np.testing.assert_array_equal(limits.max_joint_speed_rad_s, UR10E.max_joint_speed_rad_s)
    assert rig.robot_id == "ur://10.0.0.5:ur10e" and rig.real_robot is True
    with pytest.raises(CalibrationError) as exc:
        hw._ur_robot("ur:///", hw.Rig(model=UR10E), options, None)
    assert str(exc.value) == "--robot ur:// needs a host, e.g. ur://192.168.1.10"
    other = hw.Rig(model=UR10E)
    hw._ur_robot("ur://Xarm.local", other, options, None)  # only slashes are trimmed
    assert other.robot_id == "ur://Xarm.local:ur10e"


def test_unknown_schemes_are_refused_before_anything_starts():
    with contextlib.ExitStack() as stack:
        with pytest.raises(CalibrationError, match="^unknown --robot 'kuka://x'; use sim or ur"):
            hw.build("kuka://x", "sim", QUIET, stack)
        with pytest.raises(CalibrationError, match="^unknown --tracker 'ftp://x'; use sim, a dev"):
            hw.build("sim", "ftp://x", QUIET, stack)


def test_an_emscon_tracker_with_meteo_measures_the_arm_the_simulated_robot_moves():
    with (
        EmsconSimulatorProcess(noise=False, initialised=True) as sim,
        contextlib.ExitStack() as stack,
    ):
        url = sim.url + "?meteo=21.5,1000,40"
        rig = hw.build("sim", url, hw.RigOptions(seed=1, sim_control=sim.control_url), stack)
        assert isinstance(rig.tracker, hw.EmsconPort) and rig.tracker.url == url
        assert rig.tracker_id == rig.tracker.identity
        assert re.fullmatch(r"emscon:serial=\d+", rig.tracker_id)
        np.testing.assert_allclose(measure_at(rig, Q), rig.sim_cell.tool_pose(Q)[:3, 3], atol=1e-3)
        np.testing.assert_allclose(rig.tracker.measure().meteo, (21.5, 1000.0, 40.0))


def test_emscon_adapter_options_reach_the_adapter():
    assert hw.EmsconPort("emscon://h", timeout_s=0.25).driver.timeout_s == 0.25


@pytest.mark.parametrize(
    ("url", "options", "error", "message"),
    [
        ("emscon://", QUIET, CalibrationError, "^--tracker: expected emscon://HOST"),
        ("emscon://h?meteo=1,2", QUIET, CalibrationError, "^--tracker: meteo needs T,P,H"),
        ("emscon://127.0.0.1:1", QUIET, TrackerUnavailable, "^tracker at emscon://127.0.0.1:1: "),
        (
            "emscon://127.0.0.1:1",
            hw.RigOptions(sim_control="socket://127.0.0.1:1"),
            CalibrationError,
            "^--sim-control socket://127.0.0.1:1: ",
        ),
    ],
)
def test_bad_emscon_urls_and_unreachable_servers(url, options, error, message):
    with contextlib.ExitStack() as stack, pytest.raises(error, match=message):
        hw.build("sim", url, options, stack)
