"""The one decision of which parameters are free, for ``identify`` and ``plan`` alike.

Three sieves, each leaving a reason for every parameter it drops:

1. structure (:func:`calibrator.model.parameters.structural_candidates`): what the
   nominal arm's axes, the frame of the points and the tool knowledge leave
   to identify (Hayati's ``beta`` for parallel axes, no base frame in the
   base frame, ...);
2. the model's own redundancy (:func:`calibrator.model.parameters.prune` on
   :data:`GENERIC_POSES` well-spread poses of the nominal arm): what no set
   of poses could separate, and columns with no effect at all;
3. with a session only, what its poses pin down against the assumed noise
   (:func:`calibrator.identify.identifiability.select`); too few poses for
   the parameters left is an error, not a reason to drop.

A plan has no session yet: it stops after step 2.

Parameters offered after a geometric fit (the opt-in joint error terms of
:mod:`calibrator.model.joint_terms`) go through :func:`offer`: sieves 2 and 3 on
the fitting poses, at the fitted deltas, together with the geometry.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from calibrator.identify import identifiability
from calibrator.identify.problem import Problem
from calibrator.model import measurement, parameters

#: Poses of the nominal arm that reveal the model's own redundancies.
GENERIC_POSES = 64


@dataclass(frozen=True)
class FreeSet:
    """The free parameters and why the others are not.

    Attributes
    ----------
    space : calibrator.model.parameters.ParameterSpace
        Free set and first guesses.
    dropped : list of dict
        ``{"name", "reason"}`` of every candidate left out.
    information : ndarray, shape (D, D) or None
        Range-scaled Fisher information of the free set on the session's
        poses (see :func:`identifiability.scaled_information`); ``None``
        without a session.
    """

    space: parameters.ParameterSpace
    dropped: list = field(default_factory=list)
    information: np.ndarray | None = None

    @property
    def names(self) -> tuple:
        """Names of the free parameters, in :data:`calibrator.model.parameters.ALL_NAMES` order."""
        return tuple(self.space.free)


def generic_poses(
    space: parameters.ParameterSpace, orientation: bool, n: int = GENERIC_POSES
) -> measurement.Observations:
    """Well-spread poses of the nominal arm (seeded, uniform joints in ``[-pi, pi]``).

    Returns
    -------
    calibrator.model.measurement.Observations
        ``n`` poses measured exactly by the first-guess model; with
        rotations when ``orientation``.
    """
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (n, 6))
    pose = measurement.predict(space, np.zeros(space.size), q)
    return measurement.Observations(q, pose[:, :3, 3], pose[:, :3, :3] if orientation else None)


def decide(
    nominal_mdh: np.ndarray,
    frame: str,
    tool_known: bool,
    orientation: bool,
    *,
    base0: np.ndarray | None = None,
    tool0: np.ndarray | None = None,
    k: float = 0.0,
    fit: measurement.Observations | None = None,
    noise_mm: float | None = None,
) -> FreeSet:
    """Decide the free parameters.

    Parameters
    ----------
    nominal_mdh : ndarray, shape (6, 5)
        Nominal arm (mm, rad).
    frame : {'base', 'tracker'}
        Frame of the measured points.
    tool_known : bool
        Whether the tool frame is fixed.
    orientation : bool
        Whether orientation rows take part (6-DoF data and ``k > 0``).
    base0, tool0 : ndarray, shape (4, 4), optional
        First guesses of ``base2tracker`` and ``flange2tool`` (identity if absent).
    k : float
        Orientation weight (mm^2/rad^2), for the orientation rows.
    fit : calibrator.model.measurement.Observations, optional
        The session's fitting poses; without them (a plan), the structural
        and model sieves only.
    noise_mm : float, optional
        Assumed noise of one residual row (mm); needed with ``fit``.

    Returns
    -------
    FreeSet

    Raises
    ------
    IdentifiabilityError
        ``fit`` has fewer values than the model's free parameters, or
        identifies none.
    """
    base0 = np.eye(4) if base0 is None else base0
    tool0 = np.eye(4) if tool0 is None else tool0
    candidates, dropped = parameters.structural_candidates(
        nominal_mdh, frame, tool_known, orientation
    )
    space = parameters.ParameterSpace(nominal_mdh, base0, tool0, tuple(candidates))
    weight = k if orientation else 0.0
    generic = Problem.of(space, generic_poses(space, orientation), weight)
    jac = generic.jacobian(generic.zero(), names=candidates)
    kept, redundant = parameters.prune(candidates, jac, context="(for any poses)")
    dropped = dropped + redundant
    if fit is None:
        return FreeSet(space.with_free(kept), dropped)
    if noise_mm is None:
        raise ValueError("deciding on a session's poses needs its noise_mm")
    problem = Problem.of(space.with_free(kept), fit, weight)
    parameters.require_enough(problem.rows, len(kept), f"{len(fit)} fitting poses")
    jac = problem.jacobian(problem.zero())
    chosen, weak = identifiability.select(kept, jac, noise_mm)
    identifiability.require_some(chosen)
    cols = [kept.index(n) for n in chosen]
    info = identifiability.scaled_information(jac[:, cols], chosen, noise_mm)
    return FreeSet(space.with_free(chosen), dropped + weak, info)


def offer(problem: Problem, x: np.ndarray, names: Sequence[str], noise_mm: float) -> FreeSet:
    """The free set of a fitted problem with more parameters offered (joint terms).

    The offered names join the problem's free set and go through the same
    sieves as the geometry: redundancy (:func:`calibrator.model.parameters.prune`)
    and what these poses pin down against the noise
    (:func:`identifiability.select`), both on the fitting poses at ``x``
    (joint terms need the session's poses: compliance has no effect without
    their gravity torques, and a term is told from the geometry only by the
    poses' joint angles).

    Parameters
    ----------
    problem : Problem
        The fitted problem (geometry).
    x : ndarray, shape (problem.space.size,)
        Its fitted deltas.
    names : sequence of str
        Parameters offered, in :data:`calibrator.model.parameters.NAMES_WITH_TERMS`.
    noise_mm : float
        Assumed noise of one residual row (mm).

    Returns
    -------
    FreeSet
        ``space``: the kept names, geometric and offered, in name order;
        ``dropped``: every parameter left out, with its reason; no information.
    """
    values = dict(zip(problem.space.free, np.asarray(x, dtype=float), strict=True))
    wider = problem.with_free(list(problem.space.free) + [n for n in names if n not in values])
    x_wide = np.array([values.get(n, 0.0) for n in wider.space.free])
    jac = wider.jacobian(x_wide)
    free = list(wider.space.free)
    kept, redundant = parameters.prune(free, jac, context="with these poses")
    chosen, weak = identifiability.select(kept, jac[:, [free.index(n) for n in kept]], noise_mm)
    return FreeSet(wider.space.with_free(chosen), redundant + weak)


def poses_for(
    nominal_mdh: np.ndarray,
    frame: str = "tracker",
    tool_known: bool = False,
    validation_fraction: float = 0.2,
    per_parameter: float = identifiability.MIN_VALUES_PER_PARAMETER,
    orientation: bool = False,
) -> int:
    """Poses to measure so the fit keeps ``per_parameter`` values per free parameter.

    The free set is :func:`decide`'s without a session; the fitting poses
    are what ``identify``'s hold-out (``round(fraction * n)`` poses) leaves.

    Parameters
    ----------
    nominal_mdh : ndarray, shape (6, 5)
    frame, tool_known, orientation
        As for :func:`decide`; a position-only tracker gives 3 values per
        pose, a 6-DoF probe 6.
    validation_fraction : float
        Share held out, as ``identify --validation-fraction``.
    per_parameter : float
        Measured values per free parameter wanted in the fit (identify warns
        below :data:`identifiability.MIN_VALUES_PER_PARAMETER`).

    Returns
    -------
    int
    """
    free = len(decide(nominal_mdh, frame, tool_known, orientation).names)
    per_pose = 6 if orientation else 3
    n = 1
    while (n - int(round(validation_fraction * n))) * per_pose < per_parameter * free:
        n += 1
    return n
