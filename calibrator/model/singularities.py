"""How far a pose is from each of a six-axis arm's singularities.

One measure per singularity, used by the planner (to keep planned poses
clear: :func:`calibrator.cell.checks.singularity_faults`) and by program
compensation and program filtering (to name the one a failed target is
near: :func:`nearest`):

- wrist: the angle between axes 4 and 6 (they line up; on a UR arm ``|q5|``);
- elbow: the angle between the upper arm (axis 2 to axis 3) and the forearm
  (axis 3 to the wrist centre), seen along axis 2, from parallel: stretched
  out or folded (on a UR arm ``|q3|``);
- shoulder: the wrist centre's distance from the plane through axis 1
  parallel to axis 2 (over axis 1 on an arm without a shoulder offset).

Positions in the robot base frame, mm; angles deg.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import kinematics


def points(mdh: ArrayLike, q: ArrayLike) -> tuple[np.ndarray, ...]:
    """``(o1, o2, w, x1, z1, z3, z5)``, each (N, 3): points on axes 2 and 3, the
    wrist centre, x and z of the frame on axis 2, and axes 4 and 6 (base frame, mm)."""
    _, link = kinematics.chain(mdh, q, all_frames=True)
    o1, o2, w = link[:, 1, :3, 3], link[:, 2, :3, 3], link[:, 4, :3, 3]
    x1, z1, z3, z5 = link[:, 1, :3, 0], link[:, 1, :3, 2], link[:, 3, :3, 2], link[:, 5, :3, 2]
    return o1, o2, w, x1, z1, z3, z5


def margins(mdh: ArrayLike, q: ArrayLike) -> np.ndarray:
    """Each pose's distance from the wrist, elbow and shoulder singularities.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    q : array_like, shape (N, 6)
        Joint angles, rad.

    Returns
    -------
    ndarray, shape (N, 3)
        Wrist (deg), elbow (deg) and shoulder (mm) margins; 0 on the singularity.
    """
    q = kinematics.check_joints(q)
    o1, o2, w, x1, z1, z3, z5 = points(mdh, q)
    wrist = np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", z3, z5)), 0.0, 1.0)))
    # Seen along axis 2: a shoulder offset (a UR arm's 174 mm along it) is no bend.
    upper, fore = o2 - o1, w - o2
    upper = upper - np.einsum("ij,ij->i", upper, z1)[:, None] * z1
    fore = fore - np.einsum("ij,ij->i", fore, z1)[:, None] * z1
    cos_elbow = np.einsum("ij,ij->i", upper, fore) / (
        np.linalg.norm(upper, axis=1) * np.linalg.norm(fore, axis=1)
    )
    elbow = np.degrees(np.arccos(np.clip(np.abs(cos_elbow), 0.0, 1.0)))
    a1 = np.arctan2(x1[:, 1], x1[:, 0])
    shoulder = np.abs(w[:, 0] * np.cos(a1) + w[:, 1] * np.sin(a1))
    return np.column_stack([wrist, elbow, shoulder])


#: A pose closer than this to a wrist or elbow singularity is named near it (deg).
NEAR_DEG = 5.0
#: ... or closer than this to the shoulder singularity (mm).
NEAR_MM = 50.0


def nearest(mdh: ArrayLike, q_model: ArrayLike) -> list[str]:
    """Name, per pose, the singularity closest to it, with its margin.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
    q_model : array_like, shape (N, 6)
        rad.

    Returns
    -------
    list of str, length N
        E.g. ``"wrist singularity: axes 4 and 6 are 0.8 deg from parallel"``;
        empty where no singularity is within :data:`NEAR_DEG` (or
        :data:`NEAR_MM` for the shoulder).
    """
    out = []
    # The one measure of each singularity (the planner keeps its poses clear by it).
    for a, b, c in margins(mdh, q_model):
        near = [a / NEAR_DEG, b / NEAR_DEG, c / NEAR_MM]
        pick = int(np.argmin(near))
        if near[pick] > 1.0:
            out.append("")
            continue
        out.append(
            [
                f"wrist singularity: axes 4 and 6 are {a:.2f} deg from parallel",
                f"elbow singularity: the arm is {b:.1f} deg from stretched",
                f"shoulder singularity: the wrist centre is {c:.0f} mm from the plane "
                "through axis 1 parallel to axis 2",
            ][pick]
        )
    return out
