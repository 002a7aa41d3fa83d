"""The quick circle test: one circle each way, read as a ballbar reads it (docs/check.md).

A daily health check beside the 8-pose check. The arm runs the circle of
``verify --path circle`` (in the cube's test plane about P1) clockwise, then
counter-clockwise, at one speed, with the calibration's compensated commands;
the tracker streams the attained path. As a ballbar pivoted at the programmed
centre, the figures come from the radial deviation ``dr = r - R`` of each
attained point, ``r`` its distance from the programmed centre in the circle's
plane and ``R`` the programmed radius, binned by angle (:data:`BIN_DEG`, the
mean of each bin, so the tracker's noise averages out):

- **radius error** ``mean(dr)`` over both directions, mm: a wrong scale
  (a link length, the tool's length along the radius);
- **out-of-roundness** ``max(dr) - min(dr)`` over both directions, mm: every
  departure from the programmed circle a fixed-centre ballbar sees, a shifted
  centre included (a turned joint zero moves the circle as a whole, and
  tilts and stretches it);
- **centre offset**, mm: the least-squares circle's centre less the
  programmed one, in the plane (the first harmonic of ``dr``), which says how
  much of the out-of-roundness is the circle having moved;
- **reversal marks**, mm: at each angle where a joint's commanded motion
  reverses, the step in ``dr`` between the bins just before and just after
  (a ballbar's reversal spikes: backlash, stick-slip, a servo's lag), and
  the largest over both directions;
- **direction gap**, mm: the largest difference between the two directions'
  ``dr`` at the same angle (a ballbar's bidirectional deviation).

The verdict is ``flagged`` when the radius error, the out-of-roundness or
the largest reversal mark exceeds its threshold (:data:`LIMITS_MM`), else
``ok``. Units: mm, s, rad (angles in the documents in degrees).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from calibrator.verify import path_figures as ip

#: Width of the angle bins the radial deviation is averaged over, degrees.
BIN_DEG = 2.0
#: Bins on either side of a joint reversal whose means give its mark.
MARK_BINS = 2
#: Thresholds of the verdict, mm: beyond any, the circle test flags the arm.
#: A calibrated arm in a sound state keeps them with a margin of 3 to 10 (docs/check.md);
#: a joint zero turned by 0.1 mrad (a light knock) moves the circle by about 0.1 mm.
LIMITS_MM = {"radius_error_mm": 0.05, "out_of_roundness_mm": 0.1, "reversal_mm": 0.05}
#: Default tool speed along the circle, mm/s.
SPEED_MM_S = 100.0
#: The two directions, in the order they run.
DIRECTIONS = ("clockwise", "counter-clockwise")


@dataclass(frozen=True)
class Run:
    """One direction of the circle: its commanded path, joint commands and attained stream.

    Attributes
    ----------
    direction : {'clockwise', 'counter-clockwise'}
        About the counter-clockwise circle's normal.
    path : calibrator.verify.path_figures.Circle
    t_s : ndarray, shape (N,)
        Command times, s.
    q : ndarray, shape (N, 6)
        Joint commands, rad.
    stream : calibrator.verify.path_figures.Stream
        Attained path, base frame, mm, time from the aligned start of the motion.
    """

    direction: str
    path: ip.Circle
    t_s: np.ndarray
    q: np.ndarray
    stream: ip.Stream


def reversed_circle(c: ip.Circle) -> ip.Circle:
    """The same circle from the same start, travelled the other way."""
    return ip.circle(c.centre_mm, -c.normal, c.radius_mm, c.start_mm, c.turns)


def radial(ccw: ip.Circle, p_mm: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Angle and radial deviation of points about a circle.

    Parameters
    ----------
    ccw : calibrator.verify.path_figures.Circle
        The counter-clockwise circle: its start direction and normal fix the angle.
    p_mm : array_like, shape (K, 3)
        Points, base frame, mm.

    Returns
    -------
    angle : ndarray, shape (K,)
        From the start direction, counter-clockwise about the normal, rad in [0, 2 pi).
    dr : ndarray, shape (K,)
        Distance from the centre in the plane less the radius, mm.
    """
    rel = np.asarray(p_mm, dtype=float) - ccw.centre_mm
    u, w = ccw.start_mm, np.cross(ccw.normal, ccw.start_mm)
    x, y = rel @ u, rel @ w
    return np.mod(np.arctan2(y, x), 2 * np.pi), np.hypot(x, y) - ccw.radius_mm


def binned(angle: np.ndarray, dr: np.ndarray) -> np.ndarray:
    """Mean ``dr`` per :data:`BIN_DEG` angle bin, shape (360 / BIN_DEG,), NaN where empty."""
    bins = int(round(360.0 / BIN_DEG))
    k = np.minimum((angle / (2 * np.pi) * bins).astype(int), bins - 1)
    total = np.bincount(k, weights=dr, minlength=bins)
    count = np.bincount(k, minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def joint_reversals(ccw: ip.Circle, run: Run) -> list[tuple[int, float]]:
    """Where a joint's commanded motion reverses along a run: (joint from 1, angle rad)."""
    dq = np.diff(run.q, axis=0)
    # Ignore the joints that barely move: their sign flips on rounding alone.
    moving = np.abs(run.q.max(axis=0) - run.q.min(axis=0)) > 1e-4
    speed = run.path.length_mm / float(run.t_s[-1])
    found = []
    for j in np.nonzero(moving)[0]:
        sign = np.sign(dq[:, j])
        nz = np.nonzero(sign)[0]
        flips = nz[1:][sign[nz[1:]] != sign[nz[:-1]]]
        for k in flips:
            point = run.path.point(np.array([speed * run.t_s[k]]))
            found.append((int(j) + 1, float(radial(ccw, point)[0][0])))
    return found


def without_harmonic(profile: np.ndarray) -> np.ndarray:
    """A binned profile less its mean and first harmonic (the circle's size and centre).

    What is left is the local shape a reversal mark stands out of: across a few
    bins, a shifted centre's smooth swing would otherwise read as a step.
    """
    bins = len(profile)
    theta = (np.arange(bins) + 0.5) * 2 * np.pi / bins
    basis = np.column_stack([np.ones(bins), np.cos(theta), np.sin(theta)])
    ok = np.isfinite(profile)
    if ok.sum() < 3:
        return profile
    coef, *_ = np.linalg.lstsq(basis[ok], profile[ok], rcond=None)
    return profile - basis @ coef


def mark_height(profile: np.ndarray, angle: float) -> float:
    """Step of a binned profile across ``angle``: after less before, mm (NaN if unread).

    ``profile`` as :func:`without_harmonic` leaves it.
    """
    bins = len(profile)
    k = int(angle / (2 * np.pi) * bins) % bins
    before = profile[(k - np.arange(1, MARK_BINS + 1)) % bins]
    after = profile[(k + np.arange(1, MARK_BINS + 1)) % bins]
    return float(np.nanmean(after) - np.nanmean(before))


def figures(runs: list[Run]) -> dict:
    """The circle test's figures and verdict from its two runs (see the module's doc).

    Parameters
    ----------
    runs : list of Run
        Clockwise and counter-clockwise, each the same circle.

    Returns
    -------
    dict
        ``radius_error_mm``, ``out_of_roundness_mm``, ``centre_offset_mm`` (3,) and
        its length ``centre_offset_norm_mm``, ``reversal_mm``, ``marks`` (per joint
        reversal: direction, joint, angle_deg, height_mm), ``direction_gap_mm``,
        ``limits_mm``, ``exceeded`` (the figures beyond their limits) and ``verdict``.
    """
    ccw = next(r.path for r in runs if r.direction == "counter-clockwise")
    profiles: dict[str, np.ndarray] = {}
    all_dr, all_angle, marks, heights = [], [], [], []
    for run in runs:
        angle, dr = radial(ccw, run.stream.p_mm)
        profiles[run.direction] = binned(angle, dr)
        all_dr.append(dr)
        all_angle.append(angle)
        shape = without_harmonic(profiles[run.direction])
        for joint, at in joint_reversals(ccw, run):
            height = mark_height(shape, at)
            if np.isfinite(height):
                heights.append(abs(height))
            marks.append(
                {
                    "direction": run.direction,
                    "joint": joint,
                    "angle_deg": float(np.degrees(at)),
                    "height_mm": height if np.isfinite(height) else None,
                }
            )
    stacked = np.vstack(list(profiles.values()))
    angle, dr = np.concatenate(all_angle), np.concatenate(all_dr)
    # First harmonic of dr: the least-squares circle's centre, in the plane.
    cx, cy = 2 * np.mean(dr * np.cos(angle)), 2 * np.mean(dr * np.sin(angle))
    u, w = ccw.start_mm, np.cross(ccw.normal, ccw.start_mm)
    offset = cx * u + cy * w
    found = {
        "radius_error_mm": float(np.nanmean(stacked)),
        "out_of_roundness_mm": float(np.nanmax(stacked) - np.nanmin(stacked)),
        "reversal_mm": float(max(heights, default=0.0)),
    }
    gap = np.abs(stacked[0] - stacked[-1])
    exceeded = [k for k, v in found.items() if abs(v) > LIMITS_MM[k]]
    return {
        **found,
        "centre_offset_mm": offset.tolist(),
        "centre_offset_norm_mm": float(np.linalg.norm(offset)),
        "direction_gap_mm": float(np.nanmax(gap)) if np.any(np.isfinite(gap)) else None,
        "marks": marks,
        "bin_deg": BIN_DEG,
        "limits_mm": dict(LIMITS_MM),
        "exceeded": exceeded,
        "verdict": "flagged" if exceeded else "ok",
    }


def run(
    robot: Any,
    tracker: Any,
    model: Any,
    flange2tool: npt.ArrayLike,
    vplan: Any,
    speed_mm_s: float,
    calibration: Any,
    tracker2base: npt.ArrayLike,
) -> dict:
    """Run the circle both ways and compute its figures.

    Parameters
    ----------
    robot : calibrator.acquire.ports.FollowsPath
        The connected arm that runs the joint path.
    tracker : calibrator.verify.path.PathTracker
        The connected tracker that streams it.
    model : calibrator.robots.RobotDescription
    flange2tool : array_like, shape (4, 4)
        Nominal TCP, mm.
    vplan : calibrator.verify.pose.VerifyPlan
        Its cube places the circle; its first test pose gives the orientation and start.
    speed_mm_s : float
        Tool speed along the circle.
    calibration : calibrator.calibration.Calibration or None
        Compensates the commands.
    tracker2base : array_like, shape (4, 4)
        Registration, mm.

    Returns
    -------
    dict
        :func:`figures` with the commanded circle, speed and directions.
    """
    from calibrator.verify import path as verify_path

    rotation = vplan.desired[0][:3, :3]
    ccw = verify_path.test_path("circle", vplan.cube, rotation)
    assert isinstance(ccw, ip.Circle)
    runs = []
    for direction, path in zip(DIRECTIONS, (reversed_circle(ccw), ccw), strict=True):
        test = verify_path.plan_along(
            model, flange2tool, "circle", path, rotation, vplan.q_test[0], speed_mm_s, calibration
        )
        stream, _, _ = verify_path.stream_cycle(robot, tracker, test, tracker2base)
        runs.append(Run(direction, path, test.t_s, test.q, stream))
    return {
        "shape": "circle",
        "frame": "robot base (the model's)",
        "commanded": {
            "centre_mm": ccw.centre_mm.tolist(),
            "normal": ccw.normal.tolist(),
            "radius_mm": ccw.radius_mm,
            "length_mm": ccw.length_mm,
        },
        "speed_mm_s": float(speed_mm_s),
        "directions": list(DIRECTIONS),
        "compensated": calibration is not None,
        **figures(runs),
    }
