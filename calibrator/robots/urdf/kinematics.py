"""A URDF chain's MDH table, exactly, and the upright pose of the arm it describes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from calibrator.model import conventions, kinematics
from calibrator.robots.urdf.chain import (
    Chain,
    fail,
)

#: Neighbouring axes closer than this (rad) get Hayati's ``beta``, as the ROS
#: kinematics import does: a slightly tilted axis (a measured or perturbed
#: URDF) would otherwise put the common normal metres away (a huge ``d``).
NEAR_PARALLEL_RAD = 0.1


@dataclass(frozen=True)
class Kinematics:
    """A chain's MDH table and what it cannot hold (see the module docstring)."""

    mdh: np.ndarray
    base_offset: np.ndarray
    flange_offset: np.ndarray
    sign: np.ndarray  # (6,) model angle = sign * URDF angle


def joint_axes(chain: Chain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each moving joint's frame (z = its axis as turned) and the tip, at the zero pose.

    Returns
    -------
    joints : ndarray, shape (6, 4, 4)
        Base-link frame of each joint, z along the axis the model turns about (mm).
    tip : ndarray, shape (4, 4)
    sign : ndarray, shape (6,)
    """
    moving = chain.moving
    if len(moving) != 6:
        extra = " (a 7-axis arm or an arm on a track is not supported)" if len(moving) > 6 else ""
        raise fail(
            chain.path,
            f"{len(moving)} moving joints between {chain.base_link!r} and {chain.tip_link!r}: "
            f"only serial 6-axis arms are supported{extra}",
        )
    frames = chain.link_frames()
    out = np.empty((6, 4, 4))
    sign = np.ones(6)
    tip = frames[chain.tip_link]
    # Axis 6 out of the flange, so the MDH flange frame's z points away from the wrist
    # (where the tool is): from joint 5 towards the tip, else the tip frame's z.
    outward = tip[:3, 3] - frames[moving[4].child][:3, 3]
    if np.linalg.norm(outward) < 1e-6:
        outward = tip[:3, 2]
    for i, joint in enumerate(moving):
        # The joint turns the child frame about the axis given in that (child) frame.
        at = frames[joint.child]
        z = at[:3, :3] @ joint.axis
        if i == 0 and z[2] < -1e-12:
            sign[0] = -1.0  # joint 1 about the base's +z: the model angle is the URDF's negative
        if i == 5 and z @ outward < -1e-12:
            sign[5] = -1.0  # joint 6 about the outward axis: the model angle is the negative
        out[i] = _frame_on(at[:3, 3], sign[i] * z)
    return out, tip, sign


def _frame_on(origin: np.ndarray, z: np.ndarray) -> np.ndarray:
    z = z / np.linalg.norm(z)
    x = np.cross([0.0, 1.0, 0.0], z) if abs(z[1]) < 0.9 else np.cross([1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    out = np.eye(4)
    out[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    out[:3, 3] = origin
    return out


def kinematics_of(chain: Chain) -> Kinematics:
    """The chain's MDH table, exactly (see the module docstring)."""
    joints, tip, sign = joint_axes(chain)
    z = joints[:, :3, 2]
    parallel = np.linalg.norm(np.cross(z[:-1], z[1:]), axis=1) < np.sin(NEAR_PARALLEL_RAD)
    flange = _flange_on_axis(tip, z[5])
    mdh, base2frame0, residual = conventions.fit_links(joints, flange, np.zeros((6, 5)), parallel)
    if not (np.all(np.isfinite(mdh)) and np.all(np.isfinite(residual))):
        raise fail(chain.path, "the joint axes do not describe a 6R arm")
    return Kinematics(mdh, base2frame0, residual @ np.linalg.inv(flange) @ tip, sign)


def _flange_on_axis(tip: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The tip frame turned so its z is axis 6 (``z``), x as near the tip's as it goes.

    ``theta_6`` is read off the flange frame's x axis about z: from a tip
    frame whose z is not axis 6 (a ``tool0`` with x out of the flange, a
    ``link_6`` frame) it would depend on how a hair's tilt resolves, and a
    slightly perturbed copy of the arm would get a flange frame turned by 90
    or 180 degrees. The tip's x, or its y where x lies within 30 degrees of
    the axis, projected across the axis, is stable. A tip already on the axis
    is returned as it is.
    """
    z = z / np.linalg.norm(z)
    if np.linalg.norm(np.cross(tip[:3, 2], z)) < 1e-9:
        return tip
    x = tip[:3, 0] if abs(tip[:3, 0] @ z) < np.cos(np.radians(30.0)) else tip[:3, 1]
    x = x - z * (x @ z)
    x /= np.linalg.norm(x)
    out = tip.copy()
    out[:3, :3] = np.column_stack([x, np.cross(z, x), z])
    return out


def upright(mdh: np.ndarray, limits: np.ndarray, base_offset: np.ndarray) -> tuple[float, ...]:
    """Model angles holding the arm straight up with the flange pointing up.

    Joints 2 and 3 put the wrist (frame 5's origin) highest above the base
    link; joints 4 and 5 then point the flange's z axis most nearly up. Found
    on a 5-degree grid within the limits, refined on a half-degree one (the
    cell's via poses need no more).
    """

    def best(q0: np.ndarray, joints: tuple[int, int], score, step_deg: float, span_deg: float):
        axes = []
        for j in joints:
            grid = q0[j] + np.radians(np.arange(-span_deg, span_deg + step_deg / 2, step_deg))
            axes.append(grid[(grid >= limits[j, 0]) & (grid <= limits[j, 1])])
        a, b = np.meshgrid(*axes, indexing="ij")
        q = np.tile(q0, (a.size, 1))
        q[:, joints[0]], q[:, joints[1]] = a.ravel(), b.ravel()
        # Ties (a flat optimum) go to the smallest angles.
        return q[np.argmax(score(q) - 1e-6 * np.abs(q[:, joints]).sum(axis=1))]

    def wrist_height(q: np.ndarray) -> np.ndarray:
        return (base_offset @ kinematics.chain(mdh, q, all_frames=True)[1][:, 5])[:, 2, 3]

    def flange_up(q: np.ndarray) -> np.ndarray:
        return (base_offset @ kinematics.chain(mdh, q))[:, 2, 2]

    q = np.zeros(6)
    for score, joints in ((wrist_height, (1, 2)), (flange_up, (3, 4))):
        q = best(q, joints, score, 5.0, 360.0)
        q = best(q, joints, score, 0.5, 5.0)
    return tuple(float(v) for v in q)
