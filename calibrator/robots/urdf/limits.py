"""Joint limits and speeds from a URDF's ``<limit>`` elements, in model angles."""

from __future__ import annotations

import numpy as np

from calibrator.robots.urdf.chain import (
    MAX_LIMIT_RAD,
    Chain,
    fail,
)

#: A joint speed above this (rad/s) was written in deg/s (the fastest shipped wrist: 25 rad/s).
MAX_SPEED_RAD_S = 60.0


def joint_limits(chain: Chain, sign: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    limits = np.empty((6, 2))
    speeds = np.empty(6)
    for i, joint in enumerate(chain.moving):
        if joint.kind == "continuous" and (joint.lower is None or joint.upper is None):
            lo, hi = -2 * np.pi, 2 * np.pi
        elif joint.lower is None or joint.upper is None:
            raise fail(chain.path, f"joint {joint.name!r} has no lower and upper limit")
        else:
            lo, hi = joint.lower, joint.upper
        if not lo < hi:
            raise fail(chain.path, f"joint {joint.name!r}: lower limit {lo} is not below {hi}")
        if max(abs(lo), abs(hi)) > MAX_LIMIT_RAD:
            raise fail(
                chain.path,
                f"joint {joint.name!r}: limits [{lo:g}, {hi:g}] are more than two turns: "
                "written in degrees? URDF limits are radians",
            )
        limits[i] = (lo, hi) if sign[i] > 0 else (-hi, -lo)
        if joint.velocity is None or not joint.velocity > 0:
            raise fail(chain.path, f"joint {joint.name!r} has no velocity limit > 0")
        if joint.velocity > MAX_SPEED_RAD_S:
            raise fail(
                chain.path,
                f"joint {joint.name!r}: velocity {joint.velocity:g} rad/s is no arm's: "
                "written in deg/s? URDF velocities are rad/s",
            )
        speeds[i] = joint.velocity
    return limits, speeds
