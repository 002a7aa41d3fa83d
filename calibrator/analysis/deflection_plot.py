"""Deflection map over the workspace, as PNG bytes (matplotlib's Agg canvas)."""

import io

import numpy as np

from calibrator.analysis.deflection import FlexArm, deflect


def workspace_map(
    arm: FlexArm,
    pose: np.ndarray,
    joints: tuple[int, int],
    ranges: tuple[tuple[float, float], tuple[float, float]],
    grid: int = 31,
    payload_kg: float = 0.0,
) -> bytes:
    """Static hand deflection over a grid of two joints, the others at ``pose``.

    Parameters
    ----------
    arm : FlexArm
    pose : ndarray, shape (n,)
        Joint values of the joints not swept.
    joints : (int, int)
        0-based indices of the two swept joints.
    ranges : ((lo, hi), (lo, hi))
        Their ranges (rad, or mm for a prismatic joint).
    grid : int
        Points per swept joint.

    Returns
    -------
    bytes
        A PNG: the hand's position (distance from the base z axis, height) of
        every grid pose, coloured by the size of its deflection (mm).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    a = np.linspace(*ranges[0], grid)
    b = np.linspace(*ranges[1], grid)
    aa, bb = np.meshgrid(a, b, indexing="ij")
    q = np.tile(np.asarray(pose, dtype=float), (aa.size, 1))
    q[:, joints[0]], q[:, joints[1]] = aa.ravel(), bb.ravel()
    result = deflect(arm, q, payload_kg=payload_kg)
    hand = arm.frames(q)[:, -1, :3, 3]
    size = np.linalg.norm(result.hand_mm, axis=-1)
    fig = Figure(figsize=(6.0, 4.8), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    dots = ax.scatter(np.hypot(hand[:, 0], hand[:, 1]), hand[:, 2], c=size, s=14, cmap="viridis")
    fig.colorbar(dots, ax=ax, label="|hand deflection| (mm)")
    ax.set_xlabel("hand distance from base z axis (mm)")
    ax.set_ylabel("hand height (mm)")
    ax.set_title(
        f"{arm.name}\nstatic deflection, joints {joints[0] + 1} and {joints[1] + 1} swept",
        fontsize=9,
    )
    ax.set_aspect("equal", adjustable="datalim")
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()
