"""Is the data plausible for the model? Checks before fitting, and after.

A calibration fits whatever it is given: points in metres give a "perfect"
fit with every length shrunk 1000x, joints in degrees give a fit with metres
of error. Both are silent wrong answers, so the data is checked against the
model first (:func:`check_observations`, called by
:func:`calibrator.session.load`) and the identified deltas after
(:func:`check_deltas`, for the identify pipeline to call).

Before fitting:

- **magnitudes**: no coordinate beyond :data:`MAX_ABS_MM` (absurd, not
  merely out of reach);
- **joints against the model's joint limits**; values that cannot be
  radians on this arm but fit its limits as degrees are named as degrees;
- **points against the model's reach**: no point further from the cloud's
  median centre than :data:`EXTENT_FACTOR` times the reach; and the distance
  between two measured points, divided by the distance the nominal model
  gives for the same two joint vectors, is about 1 whatever the frame
  (distances do not depend on ``base2tracker``). A median ratio far from 1
  is explained if possible: joints in degrees (the ratio is about 1 with the
  joints read as degrees), or points in m, cm, inch or um; failing that, the
  points do not fit the model;
- **degenerate poses**: every pose with the same joints, or every point the same.

A ratio off 1 is refused when reading the joints as degrees explains it
(a ratio near 1 and far less scattered over the poses than in radians), or
when a unit in :data:`LENGTH_UNITS` does (to 25 %), or when it is off by more
than :data:`SCALE_REFUSE`; otherwise (ambiguous) it gives a warning string.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from calibrator.errors import CalibrationError, SessionError
from calibrator.model import kinematics
from calibrator.model.consistency import MAX_MDH

MAX_ABS_MM = 1.0e9  # 1000 km: no unit mistake explains it (um are named by the scale check)
GENERIC_JOINT_LIMIT_RAD = 2.0 * np.pi  # when the session names no model: any revolute joint
LIMIT_TOL_RAD = 1e-6  # a joint read back exactly on its limit is inside
SCALE_WARN = 1.5  # measured/nominal distance ratio beyond 1.5x either way: warn
SCALE_REFUSE = 5.0  # beyond 5x: refuse (an unknown tool or a wrong arm size stays inside)
MAX_SCALE_POSES = 2000  # poses used for the ratio (evenly spaced), bounds the cost
EXTENT_FACTOR = 3.0  # no point further than this x reach from the cloud's median centre
MIN_PAIR_MM = 20.0  # pairs of poses closer than this in the model say little about scale

#: Units a length may have been written in by mistake, as the factor to mm.
LENGTH_UNITS = {
    "metres (m)": 1000.0,
    "centimetres (cm)": 10.0,
    "inches": 25.4,
    "micrometres (um)": 1e-3,
}

#: Identified values further than this from nominal are not a calibration of
#: that arm (a unit mistake or a wrong nominal): (mm, rad). Reading a
#: calibration.json refuses them too (:func:`calibrator.calibration.load`).
PLAUSIBLE_DELTA = {"mm": 100.0, "rad": 0.5}
#: Identified-minus-nominal MDH deltas beyond these are reported (mm, rad).
DELTA_WARN_MM = 20.0
DELTA_WARN_RAD = np.deg2rad(5.0)
#: ... and beyond these refused: no real arm is that far from its drawing. The same
#: bounds as calibration.json validation, so a result that passes here also loads.
DELTA_REFUSE_MM = PLAUSIBLE_DELTA["mm"]
DELTA_REFUSE_RAD = PLAUSIBLE_DELTA["rad"]


def check_observations(
    q: np.ndarray,
    points: np.ndarray,
    nominal_mdh: np.ndarray,
    joint_limits_rad: np.ndarray | None = None,
    flange2tool: np.ndarray | None = None,
    joint_names: Sequence[str] | None = None,
    stated_q: np.ndarray | None = None,
) -> list[str]:
    """Refuse data that cannot belong to this model; return warnings for doubtful data.

    Parameters
    ----------
    q : ndarray, shape (N, 6)
        Joint angles as recorded (should be rad).
    points : ndarray, shape (N, 3)
        Measured tool points as recorded (should be mm), any frame.
    nominal_mdh : ndarray, shape (6, 5)
        Nominal MDH table (mm, rad).
    joint_limits_rad : ndarray, shape (6, 2), optional
        ``[min, max]`` per joint; +-2 pi when the model is not named.
    flange2tool : ndarray, shape (4, 4), optional
        First guess of the tool frame (mm); the flange when absent.
    joint_names : sequence of str, optional
        Names of the joint columns, for messages (``q1_rad`` ...).
    stated_q : ndarray, shape (N, 6), optional
        The joint values as the file states them (the controller's angles),
        where ``q`` is their conversion to the model's: messages name both.

    Returns
    -------
    list of str
        Warnings for the ambiguous cases (empty when all is plausible).

    Raises
    ------
    SessionError
        Naming the check that failed and the likely unit mistake.
    """
    q = np.asarray(q, dtype=float)
    points = np.asarray(points, dtype=float)
    names = list(joint_names or (f"q{i + 1}_rad" for i in range(6)))
    _check_magnitudes(points)
    # Absurd joints fail here, degrees named.
    _check_joint_limits(q, joint_limits_rad, names, stated_q)
    _check_degenerate(q, points)
    ratio, scatter, reach = scale_ratio(q, points, nominal_mdh, flange2tool)
    # The scale first: when every point is off by a unit factor, that is the message.
    warnings = []
    if ratio is not None and not _plausible_scale(ratio):
        as_degrees = scale_ratio(np.deg2rad(q), points, nominal_mdh, flange2tool)
        degrees_fit = (
            as_degrees[0] is not None
            and _plausible_scale(as_degrees[0])
            and as_degrees[1] is not None
            and scatter is not None  # both set with their ratio
            and as_degrees[1] < 0.5 * scatter  # consistent over the poses, unlike radians
        )
        warnings = _judge_scale(ratio, as_degrees[0] if degrees_fit else None, reach)
    _check_extent(points, reach)
    return warnings


def _check_magnitudes(points):
    bad = np.abs(points) > MAX_ABS_MM
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise SessionError(
            f"column {'xyz'[col]}_mm has an absurd value {points[row, col]:.6g} at row {row} "
            f"(more than {MAX_ABS_MM:g} mm from zero)"
        )


def _check_joint_limits(q, limits, names, stated=None):
    named = limits is not None
    if limits is None:
        limits = np.tile([-GENERIC_JOINT_LIMIT_RAD, GENERIC_JOINT_LIMIT_RAD], (6, 1))
    low, high = limits[:, 0] - LIMIT_TOL_RAD, limits[:, 1] + LIMIT_TOL_RAD
    outside = (q < low) | (q > high)
    if not outside.any():
        return
    row, col = np.argwhere(outside)[0]
    whose = "the model's" if named else "any revolute joint's"
    shown = q if stated is None else np.asarray(stated, dtype=float)
    as_rad = np.deg2rad(q)
    if np.abs(shown).max() > GENERIC_JOINT_LIMIT_RAD and np.all((as_rad >= low) & (as_rad <= high)):
        raise SessionError(
            f"joint values up to {np.abs(q).max():.4g} are outside {whose} limits in rad but "
            "inside them in degrees: the joints look like degrees; convert them to radians"
        )
    value = f"{shown[row, col]:.6g} rad"
    if stated is not None and shown[row, col] != q[row, col]:
        value += f" (the model's joint {col + 1}: {q[row, col]:.6g} rad)"
    raise SessionError(
        f"pose {row} (row) column {names[col]}: {value} is outside {whose} "
        f"limits [{limits[col, 0]:.4g}, {limits[col, 1]:.4g}] rad "
        f"({int(outside.any(axis=1).sum())} poses out of limits)"
    )


def _check_degenerate(q, points):
    if len(q) > 1 and np.all(q == q[0]):
        raise SessionError(
            f"all {len(q)} poses have the same joint values: nothing can be identified"
        )
    if len(points) > 1 and np.all(points == points[0]):
        raise SessionError(f"all {len(points)} poses have the same measured point")


def _check_extent(points, reach):
    """Every point within reach of the others: the arm cannot put its tool further."""
    if len(points) < 3:
        return
    centre = np.median(points, axis=0)
    distance = np.linalg.norm(points - centre, axis=1)
    # All points lie in a ball of radius `reach` around the base; the median centre is
    # within reach * sqrt(3) of the base, so no point is more than 2.8 reach from it.
    far = distance > EXTENT_FACTOR * reach
    if far.any():
        row = int(np.argmax(distance))
        raise SessionError(
            f"row {row}: the point is {distance[row]:.6g} mm from the middle of the point "
            f"cloud, beyond the arm's reach of about {reach:.0f} mm "
            f"({int(far.sum())} of {len(points)} points)"
        )


def scale_ratio(
    q: np.ndarray,
    points: np.ndarray,
    nominal_mdh: np.ndarray,
    flange2tool: np.ndarray | None = None,
) -> tuple[float | None, float | None, float]:
    """Median ratio of measured to nominal distances between poses.

    Parameters
    ----------
    q : ndarray, shape (N, 6)
        Joint angles, rad.
    points : ndarray, shape (N, 3)
        Measured points, mm, any frame.
    nominal_mdh : ndarray, shape (6, 5)
    flange2tool : ndarray, shape (4, 4), optional

    Returns
    -------
    ratio : float or None
        About 1 for consistent units; None when too few pairs of poses are
        far enough apart in the model to tell.
    scatter : float or None
        Median absolute deviation of the log ratios: small when one factor
        explains every pair (a unit mistake), large when the joints are read
        wrongly (each pair is off differently).
    reach : float
        Upper bound of the arm's reach with this tool, mm.
    """
    mdh = np.asarray(nominal_mdh, dtype=float)
    tool = np.eye(4) if flange2tool is None else np.asarray(flange2tool, dtype=float)
    reach = float(np.abs(mdh[:, 0]).sum() + np.abs(mdh[:, 3]).sum() + np.linalg.norm(tool[:3, 3]))
    n = len(q)
    if n < 3:
        return None, None, reach
    take = np.unique(np.linspace(0, n - 1, min(n, MAX_SCALE_POSES)).astype(int))
    q, points = q[take], points[take]
    model = kinematics.forward(mdh, q, tool)[:, :3, 3]
    parts = []
    m = len(take)
    for shift in np.unique(np.linspace(1, m - 1, min(m - 1, 8)).astype(int)):
        other = np.roll(np.arange(m), -shift)
        d_model = np.linalg.norm(model - model[other], axis=1)
        d_meas = np.linalg.norm(points - points[other], axis=1)
        keep = d_model > MIN_PAIR_MM
        parts.append(d_meas[keep] / d_model[keep])
    ratios = np.concatenate(parts)

    ratios = ratios[ratios > 0]
    if len(ratios) < 3:
        return None, None, reach
    logs = np.log(ratios)
    centre = np.median(logs)
    return float(np.exp(centre)), float(np.median(np.abs(logs - centre))), reach


def _plausible_scale(ratio):
    return 1.0 / SCALE_WARN <= ratio <= SCALE_WARN


def _judge_scale(ratio, ratio_if_degrees, reach):
    """Refuse (naming the likely mistake) or warn about a measured/nominal ratio off 1.

    ``ratio_if_degrees`` is given only when reading the joints as degrees fits.
    """
    describe = (
        f"distances between measured points are {ratio:.4g} times those the model gives for "
        f"the same joints (arm reach about {reach:.0f} mm)"
    )
    if ratio_if_degrees is not None:
        raise SessionError(
            f"{describe}, but {ratio_if_degrees:.3g} times if the joints are read as degrees: "
            "the joints look like degrees; convert them to radians"
        )
    unit = likely_length_unit(ratio)
    if unit is not None:
        raise SessionError(f"{describe}: the points look like {unit}, not mm")
    message = (
        f"{describe}: the points do not fit the model; are the joints in degrees, "
        "or is it the wrong model?"
    )
    if ratio < 1.0 / SCALE_REFUSE or ratio > SCALE_REFUSE:
        raise SessionError(message)
    return [message]


def likely_length_unit(ratio: float) -> str | None:
    """The unit in :data:`LENGTH_UNITS` whose factor explains ``ratio`` to within 25 %, or None.

    ``ratio`` is measured/nominal: points in metres give about 1/1000.
    """
    for name, factor in LENGTH_UNITS.items():
        if abs(np.log(ratio * factor)) < np.log(1.25):
            return name
    return None


def check_deltas(nominal_mdh: np.ndarray, identified_mdh: np.ndarray) -> list[str]:
    """Judge identified MDH parameters against the nominal table.

    For the identify pipeline, after the fit: a real arm differs from its
    drawing by fractions of a mm and of a degree; tens of mm mean a unit or
    model mistake that the fit absorbed.

    Parameters
    ----------
    nominal_mdh, identified_mdh : ndarray, shape (6, 5)
        ``a_mm, alpha_rad, theta_rad, d_mm, beta_rad`` per joint.

    Returns
    -------
    list of str
        One warning per delta beyond :data:`DELTA_WARN_MM` / :data:`DELTA_WARN_RAD`.

    Raises
    ------
    CalibrationError
        A delta beyond :data:`DELTA_REFUSE_MM` / :data:`DELTA_REFUSE_RAD`
        (or not finite): the result must not be used.
    """
    nominal = np.asarray(nominal_mdh, dtype=float)
    delta = np.asarray(identified_mdh, dtype=float) - nominal
    warnings = []
    for joint in range(delta.shape[0]):
        for col, column in enumerate(kinematics.COLUMNS):
            value = delta[joint, col]
            name = f"{column}{joint + 1}"
            is_length = kinematics.UNITS[col] == "mm"
            warn, refuse = (
                (DELTA_WARN_MM, DELTA_REFUSE_MM)
                if is_length
                else (DELTA_WARN_RAD, DELTA_REFUSE_RAD)
            )
            shown = f"{value:.4g} mm" if is_length else f"{np.rad2deg(value):.4g} deg"
            if not np.isfinite(value) or abs(value) > refuse:
                raise CalibrationError(
                    f"identified {name} is {shown} from nominal: implausible for a real arm "
                    "(check the units of the session and the model)"
                )
            if abs(value) > warn:
                limit = f"{warn:g} mm" if is_length else f"{np.rad2deg(warn):g} deg"
                warnings.append(
                    f"identified {name} is {shown} from nominal (plausible: within {limit})"
                )
    return warnings


def check_frames(frames: dict[str, np.ndarray], where: str = "calibration") -> None:
    """Refuse frames no cell has, with the bounds the session loader applies.

    A tool frame (``flange2tool``, ``tool0``) further than
    :data:`calibrator.model.consistency.MAX_MDH` mm from the flange is refused, as
    :func:`calibrator.session.load` refuses it in a session; a base frame
    (``base2tracker``, ``base0``) beyond :data:`MAX_ABS_MM`, as a measured
    point is. Everything derived from the frames (exports, compensation)
    is then as plausible as a session.

    Parameters
    ----------
    frames : dict of str to ndarray, shape (4, 4)
        By name (``"flange2tool"``...); translations in mm.
    where : str
        Named in the error (a path).

    Raises
    ------
    CalibrationError
        ``cal.json: 'flange2tool' puts the tool 9e+11 mm from the flange (more than 100000 mm)``.
    """
    for name, frame in frames.items():
        is_tool = "tool" in name
        limit = MAX_MDH["mm"] if is_tool else MAX_ABS_MM
        offset = float(np.max(np.abs(np.asarray(frame, dtype=float)[:3, 3])))
        if not offset <= limit:
            what = "the tool" if is_tool else "the robot base"
            origin = "the flange" if is_tool else "the tracker"
            raise CalibrationError(
                f"{where}: '{name}' puts {what} {offset:.6g} mm from {origin} "
                f"(more than {limit:g} mm: a unit mistake or a hand edit?)"
            )
