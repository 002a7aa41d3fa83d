"""Tolerance budget (the deflection paper): hand error from link-parameter and joint deviations.

To first order the hand's small displacement ``dS`` (three rotations, then
three translations, in the hand frame) is linear in the deviations::

    dS ~ J dp     (dp: deviations of the 30 MDH parameters a, alpha, theta, d, beta)
    dS ~ J* dq    (dq: joint-coordinate deviations; J* is J's theta columns)

J is the identification Jacobian of calibration
(:func:`calibrator.model.measurement.jacobian`) used forwards. Given a tolerance
``+-t_j`` per parameter and a distribution inside it (uniform, or normal with
``t = 3 sigma``) this module gives

* the worst case: ``sum_j |J_kj| t_j`` per component and the bound
  ``sum_j |J_pos,j| t_j`` on the position error's length;
* the statistical error: covariance ``J diag(sigma^2) J^T``, so RMS |dP|;
* a check against the nonlinear model: deviations drawn from the same
  distributions, pushed through the full forward kinematics;
* a sensitivity ranking: each parameter's share of the position variance,
  the tolerance to tighten first at the top.

Not every MDH entry is a physical quantity of a given arm: ``beta_i``
between non-parallel axes (and ``beta6``, after the last axis) is a
parameter the DH table already describes with the others
(:func:`without_meaning`); it takes no tolerance and is never ranked. With
a calibration, :func:`from_calibration` toleranced the identified
parameters by their identified standard errors instead of a uniform band.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypedDict

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.model import kinematics, measurement, parameters, rotations
from calibrator.model.parameters import MDH_NAMES, ParameterSpace

if TYPE_CHECKING:
    from calibrator.calibration import Calibration

JOINT_NAMES = tuple(f"q{i + 1}" for i in range(6))
#: Every toleranced quantity: the 30 MDH parameters, then the 6 joints.
NAMES = MDH_NAMES + JOINT_NAMES
DISTRIBUTIONS = ("uniform", "normal")
_THETA_COLS = [MDH_NAMES.index(f"theta{i + 1}") for i in range(6)]


def is_length(name: str) -> bool:
    """Whether a toleranced quantity is a length (mm) rather than an angle (rad)."""
    return name[0] in "ad" and not name.startswith("alpha")


def hand_jacobian(mdh: ArrayLike, q: ArrayLike) -> np.ndarray:
    """J: hand displacement per unit deviation of each toleranced quantity.

    Parameters
    ----------
    mdh : array_like, shape (6, 5)
        Nominal MDH table (mm, rad).
    q : array_like, shape (N, 6)
        Joint angles (rad).

    Returns
    -------
    ndarray, shape (N, 6, 36)
        Rows: rotations about the hand's x, y, z (rad), then translations along
        them (mm); columns: :data:`NAMES` (per mm or per rad).
    """
    mdh = kinematics.check_mdh(mdh)
    q = kinematics.check_joints(q)
    n = len(q)
    space = ParameterSpace(mdh, free=MDH_NAMES)
    hand = kinematics.chain(mdh, q)
    obs = measurement.Observations(q, hand[:, :3, 3], hand[:, :3, :3])
    jac = measurement.jacobian(space, np.zeros(space.size), obs, k=1.0)
    pos, rot = jac[: 3 * n].reshape(n, 3, -1), jac[3 * n :].reshape(n, 3, -1)
    to_hand = np.swapaxes(hand[:, :3, :3], 1, 2)  # base-frame vectors into the hand frame
    ds = np.concatenate([to_hand @ rot, to_hand @ pos], axis=1)  # (N, 6, 30)
    return np.concatenate([ds, ds[..., _THETA_COLS]], axis=-1)


@dataclass(frozen=True)
class Tolerances:
    """Symmetric tolerances ``+-t`` and the distribution inside them.

    Attributes
    ----------
    t : ndarray, shape (36,)
        Per :data:`NAMES` (mm or rad), >= 0.
    distribution : str
        ``'uniform'`` over ``[-t, t]`` or ``'normal'`` with ``sigma = t / 3``.
    """

    t: np.ndarray
    distribution: str = "uniform"

    def __post_init__(self):
        t = np.asarray(self.t, dtype=float)
        if t.shape != (len(NAMES),) or not np.all(np.isfinite(t)) or np.any(t < 0):
            raise CalibrationError("tolerances must be 36 finite values >= 0")
        if self.distribution not in DISTRIBUTIONS:
            raise CalibrationError(
                f"unknown distribution {self.distribution!r}; known: {', '.join(DISTRIBUTIONS)}"
            )
        object.__setattr__(self, "t", t)

    @classmethod
    def build(
        cls,
        length_mm: float,
        angle_rad: float,
        joint_rad: float,
        overrides: Mapping[str, float] | None = None,
        distribution: str = "uniform",
    ) -> Tolerances:
        """Tolerances from one value per kind plus per-name overrides (mm or rad)."""
        t = np.array(
            [
                joint_rad if n in JOINT_NAMES else length_mm if is_length(n) else angle_rad
                for n in NAMES
            ],
            dtype=float,  # integer kind values must not truncate the overrides
        )
        for name, value in (overrides or {}).items():
            if name not in NAMES:
                raise CalibrationError(f"unknown parameter {name!r}; known: {', '.join(NAMES)}")
            t[NAMES.index(name)] = value
        return cls(t, distribution)

    @property
    def sigma(self) -> np.ndarray:
        """Standard deviation of each deviation, shape (36,)."""
        return self.t / np.sqrt(3.0) if self.distribution == "uniform" else self.t / 3.0

    def sample(self, rng: np.random.Generator, m: int) -> np.ndarray:
        """``m`` deviation vectors, shape (m, 36)."""
        if self.distribution == "uniform":
            return rng.uniform(-1.0, 1.0, (m, len(NAMES))) * self.t
        return rng.standard_normal((m, len(NAMES))) * self.sigma


class Nonlinear(TypedDict):
    """The budget's check against the full kinematics (:func:`budget`'s ``nonlinear``).

    Attributes
    ----------
    samples : int
        Deviation sets drawn.
    rms_mm, p95_mm, max_mm : float
        RMS, 95th percentile and largest sampled position error |dP| (mm).
    linearisation_error : float
        RMS |dS_lin - dS| / RMS |dS| of the position (a ratio, 0 when nothing moved).
    """

    samples: int
    rms_mm: float
    p95_mm: float
    max_mm: float
    linearisation_error: float


class Ranked(TypedDict):
    """One toleranced quantity in the sensitivity ranking.

    Attributes
    ----------
    name : str
        A name of :data:`NAMES`.
    tolerance : float
        Its tolerance ``t`` (``unit``).
    unit : {'mm', 'rad'}
    share : float
        Its share of the position variance (0..1).
    worst_mm : float
        Its worst-case contribution to |dP|, mean over poses (mm).
    rms_mm : float
        Its statistical contribution to RMS |dP| (mm).
    """

    name: str
    tolerance: float
    unit: str
    share: float
    worst_mm: float
    rms_mm: float


class NotToleranced(TypedDict):
    """An entry with no physical meaning on this arm (:func:`without_meaning`) and why."""

    name: str
    reason: str


class Budget(TypedDict):
    """The tolerance budget at a set of poses (:func:`budget`; ``analyze tolerance --json``).

    Attributes
    ----------
    poses : int
    distribution : {'uniform', 'normal'}
    worst_case_mm : float
        Largest over poses of the linear bound on |dP| (mm).
    worst_case_axis_mm : float
        Largest per-axis worst case (mm).
    rms_mm : float
        Linear statistical RMS |dP| over the poses (mm).
    link_only_rms_mm, joint_only_rms_mm : float
        The same from the link parameters alone, from the joints alone (mm).
    orientation_rms_deg : float
        Linear statistical RMS orientation error (deg).
    nonlinear : Nonlinear
    ranking : list of Ranked
        By decreasing share of the position variance.
    not_toleranced : list of NotToleranced
    """

    poses: int
    distribution: str
    worst_case_mm: float
    worst_case_axis_mm: float
    rms_mm: float
    link_only_rms_mm: float
    joint_only_rms_mm: float
    orientation_rms_deg: float
    nonlinear: Nonlinear
    ranking: list[Ranked]
    not_toleranced: list[NotToleranced]


def perturbed_hand(mdh: np.ndarray, q: np.ndarray, dp: np.ndarray) -> np.ndarray:
    """Hand poses with deviations applied, by the full (nonlinear) kinematics.

    Parameters
    ----------
    mdh : ndarray, shape (6, 5)
    q : ndarray, shape (N, 6)
    dp : ndarray, shape (M, 36)
        Deviations in :data:`NAMES` order; joint deviations add to theta.

    Returns
    -------
    ndarray, shape (M, N, 4, 4)
    """
    tables = mdh + dp[:, :30].reshape(-1, 6, 5)
    tables[..., kinematics.THETA] += dp[:, 30:]
    return kinematics.chain(tables, q)


def nonlinear_displacement(mdh: np.ndarray, q: np.ndarray, dp: np.ndarray) -> np.ndarray:
    """Hand displacement ``dS`` by the full kinematics, in the hand frame.

    Returns
    -------
    ndarray, shape (M, N, 6)
        Rotation vector of ``R_nom^T R`` (rad), then ``R_nom^T (p - p_nom)`` (mm),
        directly comparable with ``J dp``.
    """

    nominal = kinematics.chain(mdh, q)
    real = perturbed_hand(mdh, q, dp)
    to_hand = np.swapaxes(nominal[:, :3, :3], 1, 2)
    rot = rotations.rotation_error(to_hand @ real[..., :3, :3], np.eye(3))
    pos = np.einsum("nij,mnj->mni", to_hand, real[..., :3, 3] - nominal[:, :3, 3])
    return np.concatenate([rot, pos], axis=-1)


def budget(
    mdh: np.ndarray,
    q: np.ndarray,
    tol: Tolerances,
    *,
    samples: int = 2000,
    seed: int = 0,
    structure: np.ndarray | None = None,
) -> Budget:
    """The tolerance budget at a set of poses.

    Parameters
    ----------
    mdh : ndarray, shape (6, 5)
        Nominal table (mm, rad).
    q : ndarray, shape (N, 6)
        Poses (rad).
    tol : Tolerances
    samples : int
        Deviation sets drawn for the nonlinear check.
    seed : int
    structure : ndarray, shape (6, 5), optional
        The nominal design whose axes decide which entries have a physical
        meaning (:func:`without_meaning`); defaults to ``mdh``. An identified
        table's axes are parallel only to within its deltas: give its
        nominal design here.

    Returns
    -------
    Budget
        ``worst_case_mm`` (max over poses of the bound on |dP|),
        ``worst_case_axis_mm`` (largest per-axis worst case), ``rms_mm``
        (linear statistical RMS |dP|, over poses), ``joint_only_rms_mm`` and
        ``link_only_rms_mm``, ``orientation_rms_deg``; ``nonlinear``:
        ``rms_mm``, ``p95_mm``, ``max_mm`` of the sampled |dP| and
        ``linearisation_error`` (RMS |dS_lin - dS| / RMS |dS|, position);
        ``ranking``: list of ``{name, tolerance, unit, share, worst_mm,
        rms_mm}`` by decreasing share of the position variance, without the
        entries that have no physical meaning on this arm
        (:func:`without_meaning`; their tolerance is taken as zero);
        ``not_toleranced``: those names with their reason.
    """
    # Entries with no physical meaning on this arm take no tolerance and no rank.
    design = mdh if structure is None else structure
    excluded = without_meaning(design)
    tol = for_arm(tol, design)
    jac = hand_jacobian(mdh, q)  # (N, 6, 36)
    jpos, jrot = jac[:, 3:], jac[:, :3]
    col_norm = np.linalg.norm(jpos, axis=1)  # (N, 36): mm per unit deviation
    worst = col_norm @ tol.t
    worst_axis = np.abs(jpos) @ tol.t  # (N, 3)
    var = tol.sigma**2
    contrib = (col_norm**2 * var).mean(axis=0)  # (36,) mean over poses, mm^2
    rms = np.sqrt(contrib.sum())
    is_joint = np.array([n in JOINT_NAMES for n in NAMES])
    rot_var = (np.sum(jrot**2, axis=1) * var).sum(axis=1).mean()

    rng = np.random.default_rng(seed)
    dp = tol.sample(rng, samples)
    ds = nonlinear_displacement(mdh, q, dp)  # (M, N, 6)
    lin = np.einsum("nkj,mj->mnk", jac, dp)
    r = np.linalg.norm(ds[..., 3:], axis=-1)
    lin_err = np.sqrt(np.mean(np.sum((lin[..., 3:] - ds[..., 3:]) ** 2, axis=-1)))
    order = np.argsort(-contrib, kind="stable")
    total = contrib.sum()
    ranking = [
        Ranked(
            name=NAMES[j],
            tolerance=float(tol.t[j]),
            unit="mm" if is_length(NAMES[j]) else "rad",
            share=float(contrib[j] / total) if total > 0 else 0.0,
            worst_mm=float((col_norm[:, j] * tol.t[j]).mean()),
            rms_mm=float(np.sqrt(contrib[j])),
        )
        for j in order
        if NAMES[j] not in excluded
    ]
    return {  # the key order is the --json file's
        "poses": len(q),
        "distribution": tol.distribution,
        "worst_case_mm": float(worst.max()),
        "worst_case_axis_mm": float(worst_axis.max()),
        "rms_mm": float(rms),
        "link_only_rms_mm": float(np.sqrt(contrib[~is_joint].sum())),
        "joint_only_rms_mm": float(np.sqrt(contrib[is_joint].sum())),
        "orientation_rms_deg": float(np.degrees(np.sqrt(rot_var))),
        "nonlinear": {
            "samples": samples,
            "rms_mm": float(np.sqrt(np.mean(r**2))),
            "p95_mm": float(np.quantile(r, 0.95)),
            "max_mm": float(r.max()),
            "linearisation_error": float(lin_err / np.sqrt(np.mean(r**2)))
            if np.any(r > 0)
            else 0.0,
        },
        "ranking": ranking,
        "not_toleranced": [NotToleranced(name=n, reason=r) for n, r in excluded.items()],
    }


def without_meaning(mdh: np.ndarray) -> dict[str, str]:
    """MDH entries that are no physical quantity of this arm, with the reason.

    These are the ``beta`` angles the structural rules leave out (Hayati's
    ``beta`` only exists between parallel axes; ``beta6`` has no axis after
    it): a tolerance on them would double-count what ``theta`` and ``alpha``
    already describe.

    Parameters
    ----------
    mdh : ndarray, shape (6, 5)

    Returns
    -------
    dict
        ``{name: reason}``.
    """
    _, dropped = parameters.structural_candidates(mdh, "base", True)
    return {d["name"]: d["reason"] for d in dropped if d["name"].startswith("beta")}


def for_arm(tol: Tolerances, mdh: np.ndarray) -> Tolerances:
    """``tol`` with the entries :func:`without_meaning` on this arm set to zero."""
    t = tol.t.copy()
    for name in without_meaning(mdh):
        t[NAMES.index(name)] = 0.0
    return Tolerances(t, tol.distribution)


#: Identified parameters are toleranced at this many standard errors.
SIGMAS = 3.0


def from_calibration(cal: Calibration, joint_rad: float) -> tuple[Tolerances, list[str]]:
    """Tolerances of a calibrated arm: what its identification left uncertain.

    Each identified MDH parameter gets ``SIGMAS`` times its standard error
    (normal deviations, so sigma is the standard error); parameters held at
    nominal get none (the identified ones absorbed their effect); joints get
    ``joint_rad``.

    Parameters
    ----------
    cal : calibrator.calibration.Calibration
    joint_rad : float
        Tolerance of each joint coordinate (rad).

    Returns
    -------
    tol : Tolerances
    used : list of str
        The MDH names toleranced from their standard error.

    Raises
    ------
    CalibrationError
        The calibration records no standard errors (an older file).
    """
    errors = (cal.fit.uncertainty or {}).get("standard_errors") or {}
    if not errors:
        raise CalibrationError(
            "the calibration records no standard errors (written by an older identify): "
            "give the tolerances with --length-tol/--angle-tol and --model"
        )
    t = np.zeros(len(NAMES))
    used = [n for n in MDH_NAMES if n in errors]
    for name in used:
        t[NAMES.index(name)] = SIGMAS * float(errors[name])
    t[len(MDH_NAMES) :] = joint_rad
    return Tolerances(t, "normal"), used
