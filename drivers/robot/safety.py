"""Safety checks before motion: joint limits and a user-set speed/acceleration cap.

A plan is checked whole before the first move (:func:`check_plan`): if any
target is outside the joint limits, or the requested speed or acceleration
exceeds the cap, nothing moves and :class:`~drivers.robot.errors.LimitsViolation`
names the first offending pose and joint. :class:`GuardedRobot` wraps any
:class:`~drivers.robot.interface.Robot` so that single moves are checked too.

Limits come from the caller (e.g. ``calibrator.robots.get(name)``); this
module never picks a robot model itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from calibrator.acquire import ports
from drivers.robot.errors import LimitsViolation
from drivers.robot.interface import N_JOINTS, Robot, real_array, real_scalar

if TYPE_CHECKING:  # drivers need no model at run time: the caller hands one in
    from calibrator import robots


@dataclass(frozen=True)
class MotionLimits:
    """What a plan may ask of the arm.

    Attributes
    ----------
    joint_limits_rad : ndarray, shape (6, 2)
        ``[min, max]`` angle of each joint, rad.
    max_speed_rad_s : float
        User cap on the leading-joint speed of a move, rad/s.
    max_accel_rad_s2 : float
        User cap on the leading-joint acceleration, rad/s^2.
    max_joint_speed_rad_s : ndarray, shape (6,), optional
        The arm's own speed limit per joint, rad/s. ``movej`` can make any
        joint the leading one, so a speed above the smallest of these is refused.
    """

    joint_limits_rad: np.ndarray
    max_speed_rad_s: float
    max_accel_rad_s2: float
    max_joint_speed_rad_s: np.ndarray | None = None

    def __post_init__(self):
        # Every limit must be a finite real number: a NaN compares False both ways and
        # would silently turn its check off.
        limits = real_array(self.joint_limits_rad, "joint_limits_rad")
        if limits.shape != (N_JOINTS, 2):
            raise ValueError(f"joint_limits_rad must have shape (6, 2), got {limits.shape}")
        if not np.all(limits[:, 0] < limits[:, 1]):
            raise ValueError(f"joint limits need min < max on every joint, got {limits.tolist()}")
        for name in ("max_speed_rad_s", "max_accel_rad_s2"):
            value = real_scalar(getattr(self, name), name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
            object.__setattr__(self, name, value)
        limits.setflags(write=False)
        object.__setattr__(self, "joint_limits_rad", limits)
        if self.max_joint_speed_rad_s is not None:
            speeds = real_array(self.max_joint_speed_rad_s, "max_joint_speed_rad_s")
            if speeds.shape != (N_JOINTS,):
                raise ValueError(f"max_joint_speed_rad_s must have shape (6,), got {speeds.shape}")
            if not np.all(np.isfinite(speeds) & (speeds > 0)):
                raise ValueError(
                    f"max_joint_speed_rad_s must be finite and > 0, got {speeds.tolist()}"
                )
            speeds.setflags(write=False)
            object.__setattr__(self, "max_joint_speed_rad_s", speeds)

    @classmethod
    def from_model(
        cls,
        model: robots.RobotDescription,
        max_speed_rad_s: float | None = None,
        max_accel_rad_s2: float | None = None,
    ) -> MotionLimits:
        """Limits from a ``calibrator.robots.RobotDescription``, optionally lowered by the user.

        The model's fixed ceilings (``move_speed_cap_rad_s``,
        ``move_accel_cap_rad_s2``) are the caps; a user value may only lower
        them. ``None`` keeps the ceiling.

        Raises
        ------
        LimitsViolation
            A user cap above the model's ceiling: an option cannot raise a
            motion limit.
        """
        caps = []
        for value, ceiling, what, unit in (
            (max_speed_rad_s, model.move_speed_cap_rad_s, "speed", "rad/s"),
            (max_accel_rad_s2, model.move_accel_cap_rad_s2, "acceleration", "rad/s^2"),
        ):
            if value is None:
                caps.append(float(ceiling))
                continue
            value = real_scalar(value, f"max {what}")
            # "not <=" so that NaN is refused too.
            if not (value <= ceiling):
                raise LimitsViolation(
                    f"{what} cap {value} {unit} above the {model.name} ceiling {ceiling} {unit}: "
                    "an option can lower a motion limit, never raise it"
                )
            caps.append(value)
        return cls(model.joint_limits_rad, caps[0], caps[1], model.max_joint_speed_rad_s)


def check_motion(limits: MotionLimits, speed_rad_s: float, accel_rad_s2: float) -> None:
    """Refuse a speed or acceleration above the caps (or not > 0).

    Raises
    ------
    LimitsViolation
    ValueError
        The speed or acceleration is not a real number (bool, complex, text).
    """
    speed_rad_s = real_scalar(speed_rad_s, "speed_rad_s")
    accel_rad_s2 = real_scalar(accel_rad_s2, "accel_rad_s2")
    if not (np.isfinite(speed_rad_s) and 0 < speed_rad_s <= limits.max_speed_rad_s):
        raise LimitsViolation(
            f"speed {speed_rad_s} rad/s outside (0, {limits.max_speed_rad_s}] (user cap)"
        )
    if limits.max_joint_speed_rad_s is not None:
        slowest = float(np.min(limits.max_joint_speed_rad_s))
        if speed_rad_s > slowest:
            raise LimitsViolation(
                f"speed {speed_rad_s} rad/s above the arm's slowest joint ({slowest:.4g} rad/s)"
            )
    if not (np.isfinite(accel_rad_s2) and 0 < accel_rad_s2 <= limits.max_accel_rad_s2):
        raise LimitsViolation(
            f"acceleration {accel_rad_s2} rad/s^2 outside (0, {limits.max_accel_rad_s2}] (user cap)"
        )


def check_plan(
    q_plan_rad: ArrayLike, limits: MotionLimits, speed_rad_s: float, accel_rad_s2: float
) -> np.ndarray:
    """Check every target of a plan, and the motion parameters, before any move.

    Parameters
    ----------
    q_plan_rad : array_like, shape (N, 6)
        Joint targets, rad, in the order they will be visited.
    limits : MotionLimits
    speed_rad_s, accel_rad_s2 : float
        The speed and acceleration the plan will be run with.

    Returns
    -------
    ndarray, shape (N, 6)
        The plan as a float array (rad).

    Raises
    ------
    LimitsViolation
        Naming the first pose (0-based plan row) and joint (``J1``..``J6``)
        out of limits; the whole plan is refused.
    ValueError
        The plan has the wrong shape or holds anything but real numbers.
    """
    plan = real_array(q_plan_rad, "plan")
    if plan.ndim != 2 or plan.shape[1] != N_JOINTS:
        raise ValueError(f"plan must have shape (N, 6), got {plan.shape}")
    check_motion(limits, speed_rad_s, accel_rad_s2)
    low, high = limits.joint_limits_rad[:, 0], limits.joint_limits_rad[:, 1]
    # NaN compares False both ways, so test "inside" and negate
    bad = ~((plan >= low) & (plan <= high))
    if bad.any():
        pose, joint = np.argwhere(bad)[0]
        n_bad = int(bad.any(axis=1).sum())
        raise LimitsViolation(
            f"pose {pose} (plan row, 0-based) joint J{joint + 1}: {plan[pose, joint]:.6g} rad "
            f"outside [{low[joint]:.6g}, {high[joint]:.6g}] rad; whole plan of {len(plan)} "
            f"poses refused ({n_bad} out of limits)",
            pose_index=int(pose),
            joint_index=int(joint),
        )
    return plan


class GuardedRobot(Robot):
    """Any robot, with every move checked against :class:`MotionLimits` first.

    Parameters
    ----------
    robot : Robot
        The robot that actually moves.
    limits : MotionLimits
    """

    def __init__(self, robot: Robot, limits: MotionLimits) -> None:
        self.robot = robot
        self.limits = limits
        # What the inner robot can do, plus the whole-plan check this wrapper adds.
        self.capabilities = frozenset(robot.capabilities) | {ports.CHECKS_PLAN}

    def check_plan(
        self, q_plan_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float
    ) -> np.ndarray:
        """:func:`check_plan` with this robot's limits; call it before the first move."""
        return check_plan(q_plan_rad, self.limits, speed_rad_s, accel_rad_s2)

    def move_joints(self, q_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float) -> np.ndarray:
        target = real_array(q_rad, "joint target")
        if target.shape != (N_JOINTS,):
            raise ValueError(f"joint target must have shape (6,), got {target.shape}")
        check_plan(target[np.newaxis], self.limits, speed_rad_s, accel_rad_s2)
        return self.robot.move_joints(target, speed_rad_s, accel_rad_s2)

    def connect(self) -> None:
        self.robot.connect()

    def close(self) -> None:
        self.robot.close()

    def actual_joints(self) -> np.ndarray:
        return self.robot.actual_joints()

    def safety_state(self) -> object:
        return self.robot.safety_state()

    def joint_temperatures(self) -> np.ndarray:
        """The inner robot's joint temperatures, degC (with ``REPORTS_TEMPERATURES``).

        Raises
        ------
        NotImplementedError
            The inner robot does not report them (it does not declare the capability).
        """
        if not ports.REPORTS_TEMPERATURES.offered_by(self.robot):
            raise NotImplementedError(f"{type(self.robot).__name__} reports no joint temperatures")
        return self.robot.joint_temperatures()

    def stop(self) -> None:
        self.robot.stop()

    def clear_protective_stop(self) -> None:
        self.robot.clear_protective_stop()
