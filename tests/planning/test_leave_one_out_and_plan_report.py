"""Design and planner cases the planning tests did not reach. Found by mutation testing (issue 44).

What leaving a pose out costs the D-optimality criterion, against leaving it
out; and a made plan's report: its origin names the description it was
checked for, and its Jacobian blocks are its own poses', row for row.
"""

from __future__ import annotations

import numpy as np

from calibrator import cell, planning, robots
from calibrator.model import frames
from calibrator.planning import design

UR10E = robots.get("ur10e")
TOOL_MM = (0.0, 0.0, 100.0)


def test_leaving_a_pose_out_costs_what_its_removal_loses():
    blocks = np.random.default_rng(44).normal(size=(8, 3, 5))
    loss = design.leave_one_out(blocks)
    whole = planning.log_det(blocks)
    for i in range(8):
        without = planning.log_det(np.delete(blocks, i, axis=0))
        assert loss[i] > 0
        np.testing.assert_allclose(loss[i], whole - without, rtol=1e-9)


def test_a_pose_alone_in_seeing_a_parameter_cannot_be_left_out():
    # Unit rows: each pose sees one parameter per axis; pose 2 alone sees parameter 4.
    blocks = np.zeros((4, 3, 4))
    for i in range(4):
        for k in range(3):
            blocks[i, k, k] = 1.0
    blocks[2, 0] = (0.0, 0.0, 0.0, 1.0)
    loss = design.leave_one_out(blocks)
    assert loss[2] == np.inf
    assert np.all(np.isfinite(np.delete(loss, 2))) and np.all(np.delete(loss, 2) > 0)


def test_a_made_plans_report_carries_its_description_and_its_own_poses_blocks():
    pool = planning.sample(planning.joint_box(UR10E.joint_limits_rad, np.radians(5)), 2000,
                           "halton", 4)  # fmt: skip
    made = planning.make_checked(UR10E, 12, cell.Cell(), TOOL_MM, candidates=pool, seed=4)
    assert made.plan.origin.model_sha256 == UR10E.digest
    assert made.plan.origin.tool_mm == TOOL_MM and made.plan.origin.tracker_at_mm is None
    tool = frames.transform(translation=TOOL_MM)
    own = planning.observability(UR10E.mdh, made.plan.q_rad, tool, names=made.names)
    assert made.blocks.shape == own.blocks.shape == (12, 3, len(made.names))
    np.testing.assert_allclose(made.blocks, own.blocks, rtol=1e-9, atol=1e-12)
