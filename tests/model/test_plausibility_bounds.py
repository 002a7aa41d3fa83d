"""Plausibility checks at their boundaries: accepted just inside, refused just outside."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.errors import CalibrationError, SessionError
from calibrator.model import kinematics, plausibility

ROBOT = robots.get("er10l-c10")
REACH = 170 + 780 + 140 + 1060 + 125  # sum |a| + sum |d| of the ER10L-C10, mm


def session_data(n=12, seed=0, scale=1.0):
    """Joints inside the limits and the nominal arm's points (flange), times ``scale``."""
    q = np.random.default_rng(seed).uniform(-2.0, 2.0, (n, 6))
    points = kinematics.forward(ROBOT.mdh, q)[:, :3, 3] * scale
    return q, points


def test_plausible_data_passes_without_warnings():
    q, points = session_data()
    assert plausibility.check_observations(q, points, ROBOT.mdh, ROBOT.joint_limits_rad) == []


def test_magnitude_limit_is_inclusive():
    points = np.zeros((2, 3))
    points[1, 2] = -1.0e9
    plausibility._check_magnitudes(points)
    points[1, 2] = -1.0e9 * (1 + 1e-12)
    with pytest.raises(SessionError) as err:
        plausibility._check_magnitudes(points)
    assert str(err.value) == (
        "column z_mm has an absurd value -1e+09 at row 1 (more than 1e+09 mm from zero)"
    )


def test_joint_limits_allow_a_micro_radian_of_read_back_noise():
    limits = ROBOT.joint_limits_rad
    q = np.zeros((3, 6))
    q[1, 2] = limits[2, 1] + 0.9e-6
    q[2, 4] = limits[4, 0] - 0.9e-6
    plausibility._check_joint_limits(q, limits, list("abcdef"))
    q[2, 4] = limits[4, 0] - 1.1e-6
    with pytest.raises(SessionError) as err:
        plausibility._check_joint_limits(q, limits, list("abcdef"))
    assert str(err.value) == (
        "pose 2 (row) column e: -3.14159 rad is outside the model's limits [-3.142, 3.142] rad "
        "(1 poses out of limits)"
    )


def test_without_a_model_any_revolute_joint_is_bounded_by_two_pi():
    q = np.zeros((4, 6))
    q[0, 0] = 2 * np.pi
    q[1, 1] = -2 * np.pi - 0.5e-6
    plausibility._check_joint_limits(q, None, list("abcdef"))
    q[2, 5] = q[3, 5] = 6.3  # above 2 pi, but 6.3 deg is inside: named as degrees
    with pytest.raises(SessionError, match="look like degrees"):
        plausibility._check_joint_limits(q, None, list("abcdef"))


def test_joints_named_as_degrees_only_when_every_value_fits_as_degrees():
    limits = np.tile([-np.pi / 2, np.pi / 2], (6, 1))
    q = np.full((3, 6), 10.0)  # 10 rad: out; 10 deg: in
    with pytest.raises(SessionError) as err:
        plausibility._check_joint_limits(q, limits, list("abcdef"))
    assert str(err.value) == (
        "joint values up to 10 are outside the model's limits in rad but inside them in "
        "degrees: the joints look like degrees; convert them to radians"
    )
    q[2, 3] = 100.0  # 100 deg is outside +-90 deg too: not degrees, just out of limits
    with pytest.raises(SessionError) as err:
        plausibility._check_joint_limits(q, limits, list("abcdef"))
    assert str(err.value).startswith("pose 0 (row) column a: 10 rad is outside the model's")
    assert str(err.value).endswith("(3 poses out of limits)")
    # Out of limits but below 2 pi: never degrees.
    q = np.full((2, 6), 1.6)
    with pytest.raises(SessionError, match=r"1\.6 rad is outside the model's limits"):
        plausibility._check_joint_limits(q, limits, list("abcdef"))


def test_generic_limits_message_names_any_revolute_joint():
    q = np.zeros((2, 6))
    q[1, 3] = -700.0  # -700 deg is beyond 2 pi as degrees too
    with pytest.raises(SessionError) as err:
        plausibility._check_joint_limits(q, None, ["q1", "q2", "q3", "q4", "q5", "q6"])
    assert str(err.value) == (
        "pose 1 (row) column q4: -700 rad is outside any revolute joint's limits "
        "[-6.283, 6.283] rad (1 poses out of limits)"
    )


def test_degenerate_sessions():
    q, points = session_data(n=3)
    plausibility._check_degenerate(q[:1], points[:1])  # one pose: nothing to compare
    same_q = np.repeat(q[:1], 3, axis=0)
    with pytest.raises(SessionError, match="all 3 poses have the same joint values"):
        plausibility._check_degenerate(same_q, points)
    same_p = np.repeat(points[:1], 3, axis=0)
    with pytest.raises(SessionError, match="all 3 poses have the same measured point"):
        plausibility._check_degenerate(q, same_p)
    q2 = same_q.copy()
    q2[2, 5] += 1e-9
    p2 = same_p.copy()
    p2[1, 0] += 1e-9
    plausibility._check_degenerate(q2, p2)


def test_extent_is_three_reaches_from_the_median_centre():
    points = np.zeros((5, 3))
    points[4, 0] = 3 * 1000.0  # median centre stays at 0
    plausibility._check_extent(points, 1000.0)
    points[4, 0] = 3 * 1000.0 + 1e-6
    with pytest.raises(SessionError) as err:
        plausibility._check_extent(points, 1000.0)
    assert str(err.value) == (
        "row 4: the point is 3000 mm from the middle of the point cloud, beyond the arm's "
        "reach of about 1000 mm (1 of 5 points)"
    )
    plausibility._check_extent(points[[0, 4]], 1.0)  # two points: no middle to judge by


def test_scale_ratio_of_scaled_points_is_that_scale_and_the_reach_adds_the_tool():
    q, points = session_data(n=30, scale=2.0)
    ratio, scatter, reach = plausibility.scale_ratio(q, points, ROBOT.mdh)
    assert ratio == pytest.approx(2.0, rel=1e-9)
    assert scatter == pytest.approx(0.0, abs=1e-9)
    assert reach == pytest.approx(REACH)
    tool = np.eye(4)
    tool[:3, 3] = [30.0, 0.0, 40.0]
    assert plausibility.scale_ratio(q, points, ROBOT.mdh, tool)[2] == pytest.approx(REACH + 50)
    assert plausibility.scale_ratio(q[:2], points[:2], ROBOT.mdh) == (None, None, REACH)


def test_scale_ratio_is_the_median_over_pairs_and_ignores_close_pairs():
    q, points = session_data(n=40, seed=1)
    rng = np.random.default_rng(2)
    factor = np.exp(rng.normal(0, 0.01, 40))  # each point scaled about the origin a bit
    ratio, scatter, _ = plausibility.scale_ratio(q, points * factor[:, None], ROBOT.mdh)
    assert 0.97 < ratio < 1.03 and 0.0 < scatter < 0.05
    # Poses whose nominal points are all within 20 mm of each other: no pair to judge.
    q = np.zeros((5, 6))
    q[:, 5] = np.linspace(0, 1, 5)  # only the flange turns: the flange point stays
    q[:, 0] = np.linspace(0, 0.005, 5)  # and joint 1 turns < 20 mm at the flange
    points = kinematics.forward(ROBOT.mdh, q)[:, :3, 3]
    assert plausibility.scale_ratio(q, points, ROBOT.mdh)[0] is None


def test_scale_ratio_samples_evenly_spaced_poses_up_to_the_cap(monkeypatch):
    q, points = session_data(n=10)
    wild = [1, 3, 5, 7, 8]  # the poses an even sample of 5 out of 10 leaves out
    points[wild] += np.random.default_rng(4).uniform(-2000, 2000, (5, 3))
    ratio, scatter, _ = plausibility.scale_ratio(q, points, ROBOT.mdh)
    assert scatter > 0.05
    monkeypatch.setattr(plausibility, "MAX_SCALE_POSES", 5)  # poses 0, 2, 4, 6, 9
    ratio, scatter, _ = plausibility.scale_ratio(q, points, ROBOT.mdh)
    assert ratio == pytest.approx(1.0, rel=1e-9) and scatter == pytest.approx(0.0, abs=1e-9)


def test_plausible_scale_bounds_are_inclusive():
    assert plausibility._plausible_scale(1.5)
    assert plausibility._plausible_scale(1 / 1.5)
    assert not plausibility._plausible_scale(1.5 * (1 + 1e-12))
    assert not plausibility._plausible_scale(1 / 1.5 * (1 - 1e-12))


@pytest.mark.parametrize(
    ("ratio", "unit"),
    [
        (1e-3, "metres (m)"),
        (1e-3 * 1.249, "metres (m)"),
        (1e-3 / 1.249, "metres (m)"),
        (1e-3 * 1.251, None),
        (1e-3 / 1.251, None),
        (0.1, "centimetres (cm)"),
        (1 / 25.4, "inches"),
        (1e3 * 1.2, "micrometres (um)"),
        (1.0, None),
    ],
)
def test_likely_length_unit_within_25_percent(ratio, unit):
    assert plausibility.likely_length_unit(ratio) == unit


def test_judge_scale_refuses_or_warns_with_the_reason():
    describe = (
        "distances between measured points are {r} times those the model gives for the "
        "same joints (arm reach about 2275 mm)"
    )
    with pytest.raises(SessionError) as err:
        plausibility._judge_scale(0.0123, 0.98765, 2275.0)
    assert str(err.value) == (
        describe.format(r="0.0123") + ", but 0.988 times if the joints are read as degrees: "
        "the joints look like degrees; convert them to radians"
    )
    with pytest.raises(SessionError) as err:
        plausibility._judge_scale(0.001, None, 2275.0)
    assert (
        str(err.value) == describe.format(r="0.001") + ": the points look like metres (m), not mm"
    )
    warning = (
        describe.format(r="{r}") + ": the points do not fit the model; are the joints in "
        "degrees, or is it the wrong model?"
    )
    assert plausibility._judge_scale(5.0, None, 2275.0) == [warning.format(r="5")]
    assert plausibility._judge_scale(0.2, None, 2275.0) == [warning.format(r="0.2")]
    for ratio in (5.0 * (1 + 1e-9), 0.2 * (1 - 1e-9)):
        with pytest.raises(SessionError) as err:
            plausibility._judge_scale(ratio, None, 2275.0)
        assert str(err.value).endswith("are the joints in degrees, or is it the wrong model?")


def test_points_in_metres_are_refused_as_metres():
    q, points = session_data(n=20, scale=1e-3)
    with pytest.raises(SessionError, match=r"look like metres \(m\), not mm"):
        plausibility.check_observations(q, points, ROBOT.mdh, ROBOT.joint_limits_rad)


def test_joints_in_degrees_within_the_radian_limits_are_named_by_the_scale():
    # Small angles: degrees read as radians stay within +-pi, so only the scale tells.
    rng = np.random.default_rng(3)
    q_rad = rng.uniform(-0.05, 0.05, (30, 6))
    q_rad[:, 1] = rng.uniform(-1.0, 1.0, 30)
    q_rad[:, 2] = rng.uniform(-1.0, 1.0, 30)
    points = kinematics.forward(ROBOT.mdh, q_rad)[:, :3, 3]
    q_deg = np.degrees(q_rad)
    assert np.abs(q_deg).max() < 60  # beyond 2 pi: but the scale check comes after limits
    with pytest.raises(SessionError, match="look like degrees"):
        plausibility.check_observations(q_deg, points, ROBOT.mdh)


def test_a_scale_of_two_is_only_a_warning():
    q, points = session_data(n=20, scale=2.0)
    warnings = plausibility.check_observations(q, points, ROBOT.mdh, ROBOT.joint_limits_rad)
    assert len(warnings) == 1 and warnings[0].startswith("distances between measured points are 2 ")
    q, points = session_data(n=20, scale=1.5)
    assert plausibility.check_observations(q, points, ROBOT.mdh, ROBOT.joint_limits_rad) == []


def test_a_far_point_is_refused_after_the_scale():
    q, points = session_data(n=20)
    points[3] += [4 * REACH, 0, 0]
    with pytest.raises(SessionError, match="row 3: the point is"):
        plausibility.check_observations(q, points, ROBOT.mdh, ROBOT.joint_limits_rad)


def test_check_deltas_warn_and_refuse_boundaries():
    nominal = ROBOT.mdh
    mdh = nominal.copy()
    mdh[1, kinematics.A] += 20.0
    mdh[2, kinematics.ALPHA] += np.deg2rad(5.0)
    assert plausibility.check_deltas(nominal, mdh) == []
    mdh[1, kinematics.A] += 0.001
    mdh[2, kinematics.ALPHA] += 1e-6
    mdh[5, kinematics.D] -= 100.0  # at the refusal bound: still only a warning
    mdh[4, kinematics.BETA] -= 0.5
    assert plausibility.check_deltas(nominal, mdh) == [
        "identified a2 is 20 mm from nominal (plausible: within 20 mm)",
        "identified alpha3 is 5 deg from nominal (plausible: within 5 deg)",
        "identified beta5 is -28.65 deg from nominal (plausible: within 5 deg)",
        "identified d6 is -100 mm from nominal (plausible: within 20 mm)",
    ]
    bad = mdh.copy()
    bad[5, kinematics.D] -= 1e-6
    with pytest.raises(CalibrationError) as err:
        plausibility.check_deltas(nominal, bad)
    assert str(err.value) == (
        "identified d6 is -100 mm from nominal: implausible for a real arm (check the units "
        "of the session and the model)"
    )
    bad = mdh.copy()
    bad[0, kinematics.THETA] = np.nan
    with pytest.raises(CalibrationError, match="identified theta1 is nan deg from nominal"):
        plausibility.check_deltas(nominal, bad)
    bad = mdh.copy()
    bad[3, kinematics.THETA] += 0.5 + 1e-6
    with pytest.raises(CalibrationError, match="identified theta4 is 28.65 deg"):
        plausibility.check_deltas(nominal, bad)


def test_joints_read_back_exactly_on_the_tolerance_edge_are_inside():
    limits = ROBOT.joint_limits_rad
    q = np.zeros((2, 6))
    q[0] = limits[:, 1] + plausibility.LIMIT_TOL_RAD
    q[1] = limits[:, 0] - plausibility.LIMIT_TOL_RAD
    plausibility._check_joint_limits(q, limits, list("abcdef"))


def test_check_observations_uses_the_model_limits_and_names_the_column():
    q, points = session_data()
    limits = ROBOT.joint_limits_rad.copy()
    limits[1] = [-2.5, 2.5]
    q[4, 1] = 2.6  # inside any revolute joint's limits, outside this model's
    with pytest.raises(
        SessionError, match=r"^pose 4 \(row\) column q2_rad: 2\.6 rad is outside the model's"
    ):
        plausibility.check_observations(q, points, ROBOT.mdh, limits)
    with pytest.raises(SessionError, match=r"^pose 4 \(row\) column J2: 2\.6 rad"):
        plausibility.check_observations(
            q, points, ROBOT.mdh, limits, joint_names=list("J" + c for c in "123456")
        )


def test_the_scale_check_measures_with_the_tool():
    q = np.random.default_rng(5).uniform(-2.0, 2.0, (20, 6))
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 1500.0, 1500.0]  # a long probe: the flange's distances are far off
    points = kinematics.forward(ROBOT.mdh, q, tool)[:, :3, 3]
    ratio, _, reach = plausibility.scale_ratio(q, points, ROBOT.mdh, tool)
    assert ratio == pytest.approx(1.0, rel=1e-9)
    assert plausibility.scale_ratio(q, points, ROBOT.mdh)[0] > 1.5  # would give a warning
    assert plausibility.check_observations(q, points, ROBOT.mdh, flange2tool=tool) == []


def degrees_session(tool=None, n=30):
    """Small joint moves (|q| < 0.1 rad) recorded in degrees: within +-2 pi as numbers."""
    rng = np.random.default_rng(3)
    q_rad = rng.uniform(-0.1, 0.1, (n, 6))
    points = kinematics.forward(ROBOT.mdh, q_rad, tool)[:, :3, 3]
    q_deg = np.degrees(q_rad)
    assert np.abs(q_deg).max() < 2 * np.pi  # the joint limits cannot tell
    return q_deg, points


def test_joints_in_degrees_are_named_by_the_scale_check():
    q_deg, points = degrees_session()
    with pytest.raises(SessionError) as err:
        plausibility.check_observations(q_deg, points, ROBOT.mdh)
    assert ", but 1 times if the joints are read as degrees: the joints look like degrees" in str(
        err.value
    )


def test_joints_in_degrees_with_a_long_tool_are_named_by_the_scale_check():
    tool = np.eye(4)
    tool[:3, 3] = [0.0, 600.0, 900.0]
    q_deg, points = degrees_session(tool)
    with pytest.raises(SessionError, match=", but 1 times if the joints are read as degrees"):
        plausibility.check_observations(q_deg, points, ROBOT.mdh, flange2tool=tool)


def test_two_identical_poses_are_degenerate():
    q, points = session_data(n=2)
    with pytest.raises(SessionError, match="all 2 poses have the same joint values"):
        plausibility._check_degenerate(np.repeat(q[:1], 2, axis=0), points)
    with pytest.raises(SessionError, match="all 2 poses have the same measured point"):
        plausibility._check_degenerate(q, np.repeat(points[:1], 2, axis=0))


def test_extent_of_three_points_is_judged():
    points = np.zeros((3, 3))
    points[2, 1] = 3001.0
    with pytest.raises(SessionError, match="row 2: the point is 3001 mm"):
        plausibility._check_extent(points, 1000.0)


def test_a_cloud_far_from_the_origin_is_judged_from_its_own_middle():
    # Tracker frame: the points are 100 m from the tracker's origin, within reach of each other.
    rng = np.random.default_rng(6)
    points = [1.0e5, -1.0e5, 3.0e4] + rng.uniform(-1000, 1000, (20, 3))
    plausibility._check_extent(points, 1000.0)
    points[7] += [0.0, 0.0, 4000.0]
    with pytest.raises(SessionError, match="^row 7: "):
        plausibility._check_extent(points, 1000.0)


def test_three_poses_are_enough_for_a_scale_ratio():
    q, points = session_data(n=3, scale=2.0)
    ratio, scatter, _ = plausibility.scale_ratio(q, points, ROBOT.mdh)
    assert ratio == pytest.approx(2.0, rel=1e-9) and scatter == pytest.approx(0.0, abs=1e-9)
