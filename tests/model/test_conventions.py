"""Exact conversions between tables: the joint frames, the fitted tables and the
size of what a form cannot hold, against products written out by hand and
scipy's rotations."""

import numpy as np
import pytest
from export_kit import calibrated, poses, rot
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.model import conventions, kinematics
from calibrator.model.kinematics import ALPHA, BETA, THETA, A, D


def link_by_hand(row):
    """``Rz(theta) Tz(d) Tx(a) Rx(alpha) Ry(beta)`` for one MDH row, (4, 4)."""
    out = np.eye(4)
    out[:3, :3] = rot("z", row[THETA])
    tz, tx = np.eye(4), np.eye(4)
    tz[2, 3], tx[0, 3] = row[D], row[A]
    turn = np.eye(4)
    turn[:3, :3] = rot("x", row[ALPHA]) @ rot("y", row[BETA])
    return out @ tz @ tx @ turn


def test_link_and_joint_frames_are_the_products_of_the_rows():
    mdh = calibrated("ur10e", seed=51).mdh.copy()  # read-only: a frozen calibration
    mdh[5, BETA] = 0.003
    for row in mdh:
        np.testing.assert_allclose(conventions.link(row), link_by_hand(row), atol=1e-12)
    joints, flange = conventions.joint_frames(mdh)
    assert joints.shape == (6, 4, 4) and flange.shape == (4, 4)
    t = np.eye(4)
    for i in range(6):
        np.testing.assert_allclose(joints[i], t, atol=1e-9)
        t = t @ link_by_hand(mdh[i])
    np.testing.assert_allclose(flange, t, atol=1e-9)


def test_an_mdh_table_with_beta6_converts_to_itself():
    """Any MDH table, beta6 included, is held exactly by the Hayati form."""
    cal = calibrated("ur10e", seed=52)
    mdh = cal.mdh.copy()
    mdh[5, BETA] = 0.002
    back, residual = conventions.dh_to_mdh(mdh, robots.get("ur10e").mdh)
    np.testing.assert_allclose(back, mdh, atol=1e-9)
    np.testing.assert_allclose(residual, np.eye(4), atol=1e-9)
    # Standard DH has no beta6: the residual is exactly the turn it leaves.
    dh, residual = conventions.mdh_to_dh(mdh, robots.get("ur10e").mdh)
    assert np.all(dh[:, BETA] == 0.0)
    assert conventions.residual_size(residual)[1] == pytest.approx(0.002, rel=1e-6)


def test_a_calibrated_reference_keeps_hayati_where_its_axes_are_nearly_parallel():
    reference = calibrated("ur10e", seed=53).mdh  # axes 2-3-4 parallel to a few mrad
    arm = calibrated("ur10e", seed=54).mdh
    mdh, residual = conventions.dh_to_mdh(arm, reference)
    np.testing.assert_allclose(mdh[1:3, D], reference[1:3, D], atol=1e-9)
    q = poses(40, seed=2)
    got = kinematics.chain(mdh, q) @ residual
    want = kinematics.chain(arm, q)
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)


def mounted_fit(seed, rotation, origin):
    """Fit an arm whose base sits at ``rotation``, ``origin``; check frame 0 and chain.

    Frame 0 must be a proper rigid frame with z along joint 1's axis, and frame 0
    followed by the fitted table must be the mounted arm. Returns frame 0.
    """
    arm = calibrated("ur10e", seed=seed, trailing=False).mdh
    joints, flange = conventions.joint_frames(arm)
    mount = np.eye(4)
    mount[:3, :3], mount[:3, 3] = rotation, origin
    joints, flange = mount @ joints, mount @ flange
    mdh, base2frame0, residual = conventions.fit_links(
        joints, flange, arm, kinematics.parallel_axes(arm, tol=0.1), beta6=True
    )
    r = base2frame0[:3, :3]
    np.testing.assert_allclose(r.T @ r, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(r[:, 2], joints[0, :3, 2], atol=1e-12)
    q = poses(30, seed=seed)
    got = base2frame0 @ kinematics.chain(mdh, q) @ residual
    want = mount @ kinematics.chain(arm, q)
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, :3, :3], want[:, :3, :3], rtol=0, atol=1e-9)
    return base2frame0


@pytest.mark.parametrize("tilt", [(0.02, 0.0), (0.0, 0.03), (0.01, -0.02)])
def test_a_tilted_first_axis_gives_a_rigid_frame_0(tilt):
    """Joint 1's axis tilted about x and y."""
    mounted_fit(55, rot("x", tilt[0]) @ rot("y", tilt[1]), [10.0, -20.0, 5.0])


@pytest.mark.parametrize("angle", [1e-10, 1e-4, 0.3, 2.0, 3.0])
def test_residual_size_is_the_offset_and_the_rotation_angle(angle):
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    t = np.eye(4)
    t[:3, :3] = Rotation.from_rotvec(angle * axis).as_matrix()
    t[:3, 3] = [3.0, -4.0, 12.0]
    mm, rad = conventions.residual_size(t)
    assert mm == pytest.approx(13.0, rel=1e-15)
    assert rad == pytest.approx(angle, rel=1e-7)


@pytest.mark.parametrize("axis", [[1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [2.0, -1.0, 0.5]])
def test_residual_size_of_a_half_turn_is_pi(axis):
    axis = np.array(axis) / np.linalg.norm(axis)
    t = np.eye(4)
    t[:3, :3] = Rotation.from_rotvec(np.pi * axis).as_matrix()
    mm, rad = conventions.residual_size(t)  # the trace may round a hair below -1
    assert mm == 0.0 and rad == pytest.approx(np.pi, abs=1e-7)


def round_trip_reproduces(mdh, reference):
    """mdh -> standard DH -> MDH again: the same table, the same chain."""
    dh, res_dh = conventions.mdh_to_dh(mdh, reference)
    back, res_back = conventions.dh_to_mdh(dh, reference)
    q = poses(30, seed=9)
    want = kinematics.chain(mdh, q)
    for table, residual in ((dh, res_dh), (back, res_back)):
        got = kinematics.chain(table, q) @ residual
        np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)
        np.testing.assert_allclose(got[:, :3, :3], want[:, :3, :3], rtol=0, atol=1e-9)
    return back, res_back


def test_intersecting_axes_with_turned_links_convert_exactly():
    """a = 0 where axes meet (joints 1-2, 4-5, 5-6 of a UR): the x axis lies along
    the common perpendicular, wherever theta turned it."""
    nominal = robots.get("ur10e").mdh
    mdh = nominal.copy()
    mdh[:, THETA] += [0.02, -0.01, 0.015, 0.03, -0.025, 0.01]
    mdh[:, ALPHA] += [0.001, 0.0, 0.0, -0.002, 0.0015, 0.0]
    assert np.all(mdh[[0, 3, 4], A] == 0.0)
    back, residual = round_trip_reproduces(mdh, nominal)
    np.testing.assert_allclose(back, mdh, atol=1e-9)
    np.testing.assert_allclose(residual, np.eye(4), atol=1e-9)


def test_a_table_with_quarter_turn_thetas_comes_back_unchanged():
    """The ER10L-C10 has theta2 = -90 deg: of the two equivalent x axes, the one
    nearer the reference is kept, so the table comes back as it was."""
    nominal = robots.get("er10l-c10").mdh
    mdh = calibrated("er10l-c10", seed=56, trailing=False).mdh
    back, _ = round_trip_reproduces(mdh, nominal)
    np.testing.assert_allclose(back, mdh, atol=1e-9)


def test_a_flange_turned_half_way_round_is_read_off_exactly():
    """alpha6 near pi (a flange mounted upside down): arcsin alone gives the wrong
    branch; the table still holds alpha6 and beta6 exactly."""
    reference = robots.get("ur10e").mdh.copy()
    reference[5, ALPHA] = np.pi
    mdh = reference.copy()
    mdh[5, ALPHA] = np.pi - 0.003
    mdh[5, BETA] = 0.002
    mdh[5, A] = 0.4
    back, residual = conventions.dh_to_mdh(mdh, reference)
    np.testing.assert_allclose(back, mdh, atol=1e-9)
    np.testing.assert_allclose(residual, np.eye(4), atol=1e-9)
    # Standard DH (no beta6) of the same flange without beta6: exact as well.
    mdh[5, BETA] = 0.0
    dh, residual = conventions.mdh_to_dh(mdh, reference)
    np.testing.assert_allclose(residual, np.eye(4), atol=1e-9)
    assert dh[5, ALPHA] == pytest.approx(np.pi - 0.003, abs=1e-9) and dh[5, BETA] == 0.0


def test_a_first_axis_along_the_base_x_axis_gives_a_rigid_frame_0():
    """A robot on a wall: joint 1 turns about the base x axis."""
    base2frame0 = mounted_fit(57, rot("y", np.pi / 2), [0.0, 50.0, 700.0])
    np.testing.assert_allclose(base2frame0[:3, 2], [1.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(base2frame0[:3, 3], [0.0, 50.0, 700.0], atol=1e-9)


def craig_chain_by_hand(table, q):
    """Craig's ``Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(q_i) Tz(d_i)``, multiplied out, (4, 4)."""
    out = np.eye(4)
    for (alpha, a, d), qi in zip(table, q, strict=True):
        rx, tx, rz, tz = np.eye(4), np.eye(4), np.eye(4), np.eye(4)
        rx[:3, :3], rz[:3, :3] = rot("x", alpha), rot("z", qi)
        tx[0, 3], tz[2, 3] = a, d
        out = out @ rx @ tx @ rz @ tz
    return out


def test_a_craig_table_is_an_mdh_table_after_a_base_offset():
    rng = np.random.default_rng(5)
    table = np.column_stack(
        [rng.uniform(-np.pi, np.pi, 6), rng.uniform(-500, 500, 6), rng.uniform(-500, 500, 6)]
    )
    base, mdh = conventions.craig_to_mdh(table)
    assert np.all(mdh[:, BETA] == 0) and np.all(mdh[:, THETA] == 0)
    q = rng.uniform(-np.pi, np.pi, (5, 6))
    for pose, hand in zip(q, kinematics.chain(mdh, q), strict=True):
        np.testing.assert_allclose(base @ hand, craig_chain_by_hand(table, pose), atol=1e-9)
    with pytest.raises(ValueError, match=r"Craig DH table must be 6 x 3, got \(5, 3\)"):
        conventions.craig_to_mdh(table[:5])


def test_standard_dh_is_mdh_without_beta_and_short_arms_end_in_identity_links():
    rng = np.random.default_rng(6)
    table = np.column_stack(  # [theta_offset, s, h, alpha], five joints
        [rng.uniform(-np.pi, np.pi, 5), rng.uniform(-900, 900, 5), rng.uniform(-900, 900, 5),
         rng.uniform(-np.pi, np.pi, 5)]
    )  # fmt: skip
    mdh = conventions.standard_dh_to_mdh(table)
    assert mdh.shape == (6, 5) and np.all(mdh[5] == 0) and np.all(mdh[:, BETA] == 0)
    q = rng.uniform(-np.pi, np.pi, 6)
    _, frames = kinematics.chain(mdh, q, all_frames=True)
    t = np.eye(4)
    for i, (theta, s, h, alpha) in enumerate(table):
        m = np.eye(4)
        m[:3, :3] = rot("z", theta + q[i]) @ rot("x", alpha)
        m[:3, 3] = [h * np.cos(theta + q[i]), h * np.sin(theta + q[i]), s]
        t = t @ m
        np.testing.assert_allclose(frames[0, i + 1], t, atol=1e-9)
    np.testing.assert_array_equal(conventions.standard_dh_to_mdh(table[np.newaxis])[0], mdh)
    with pytest.raises(ValueError, match="standard DH table"):
        conventions.standard_dh_to_mdh(np.zeros((7, 4)))
