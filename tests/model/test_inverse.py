"""The inverse kinematics of calibrator.model.inverse: each target's outcome
says whether it succeeded and why not, and the Jacobian is the derivative of
the tool pose."""

import numpy as np

from calibrator import robots
from calibrator.model import frames, inverse, kinematics, rotations

UR10E = robots.get("ur10e")
TOOL = frames.transform(None, [0.0, 0.0, 100.0])


def test_each_target_says_whether_it_was_reached_and_why_not():
    q = np.array([[0.3, -1.5, 1.2, -1.0, 1.4, 0.2]] * 3)
    targets = kinematics.tool_poses(UR10E.mdh, q, TOOL)
    targets[1, :3, 3] = [5000.0, 0.0, 0.0]  # 5 m away: out of reach
    limits = UR10E.joint_limits_rad.copy()
    limits[2] = [-3.0, 1.0]  # the targets' joint 3 (1.2 rad) is past this
    start = q + 0.01
    sol = inverse.solve(UR10E.mdh, targets, start, TOOL, limits)
    assert sol.converged.tolist() == [True, False, True]
    assert sol.ok.tolist() == [False, False, False]
    assert sol.reason.tolist() == [
        inverse.OUTSIDE_LIMITS,
        inverse.NOT_REACHED,
        inverse.OUTSIDE_LIMITS,
    ]
    wide = inverse.solve(UR10E.mdh, targets[[0]], start[[0]], TOOL, UR10E.joint_limits_rad)
    assert wide.ok.tolist() == [True] and wide.reason.tolist() == [inverse.REACHED]


def test_the_jacobian_is_the_derivative_of_the_tool_point_and_turn():
    rng = np.random.default_rng(4)
    q = rng.uniform(-2.0, 2.0, (3, 6))
    jac, pose = inverse.jacobian(UR10E.mdh, q, TOOL)
    np.testing.assert_allclose(pose, kinematics.tool_poses(UR10E.mdh, q, TOOL), atol=1e-12)
    h = 1e-6
    for k in range(6):
        dq = np.zeros(6)
        dq[k] = h
        ahead = kinematics.tool_poses(UR10E.mdh, q + dq, TOOL)
        behind = kinematics.tool_poses(UR10E.mdh, q - dq, TOOL)
        move = (ahead[:, :3, 3] - behind[:, :3, 3]) / (2 * h)
        turn = rotations.rotation_error(ahead[:, :3, :3], behind[:, :3, :3]) / (2 * h)
        np.testing.assert_allclose(jac[:, :3, k], move, atol=1e-4)
        np.testing.assert_allclose(jac[:, 3:, k], turn, atol=1e-6)
