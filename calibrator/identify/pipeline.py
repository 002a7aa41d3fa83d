"""``identify``: from a session to identified parameters and their accuracy."""

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from calibrator import measurement, parameters
from calibrator.errors import IdentifiabilityError
from calibrator.identify import initial, objective, pso, refine, report

METHODS = ("hybrid", "pso", "lm")
#: Default orientation weight (mm^2/rad^2): 1 mrad weighs as 0.1 mm, about
#: the ratio of a 6-DoF probe's angular noise to a tracker's point noise.
DEFAULT_K = 1.0e4
#: Most points of the swarm's convergence curve kept in ``details``.
CONVERGENCE_POINTS = 500


@dataclass(frozen=True)
class Options:
    """Settings of one identification (CLI flags of ``calibrator identify``).

    ``on_generation(generation, best_cost)`` is called after each swarm
    generation, for progress displays.
    """

    method: str = "hybrid"
    particles: int = 20
    generations: int = 2000
    k: float | None = None
    validation_fraction: float = 0.2
    seed: int = 0
    tool_known: bool | None = None
    on_generation: Callable | None = field(default=None, compare=False)


@dataclass
class Result:
    """Everything ``identify`` found, ready for calibration.json."""

    space: parameters.ParameterSpace
    x: np.ndarray
    dropped: list
    stats: dict
    options: Options
    k: float
    fit_index: np.ndarray
    validation_index: np.ndarray
    details: dict = field(default_factory=dict)

    @property
    def mdh(self):
        """Identified MDH table, shape (6, 5)."""
        return self.space.unpack(self.x)[0]

    @property
    def base2tracker(self):
        return self.space.unpack(self.x)[1]

    @property
    def flange2tool(self):
        return self.space.unpack(self.x)[2]


def split(n_poses, fraction, seed):
    """Seeded split of pose indices into fitting and held-out sets.

    Returns
    -------
    fit, validation : ndarray of int
        Sorted indices; ``validation`` has ``round(fraction * n)`` poses.
    """
    if not 0.0 <= fraction < 1.0:
        raise IdentifiabilityError(f"validation fraction must be in [0, 1), got {fraction}")
    n_val = int(round(fraction * n_poses))
    order = np.random.default_rng(seed).permutation(n_poses)
    return np.sort(order[n_val:]), np.sort(order[:n_val])


def identify(session, options=Options()):
    """Identify the free parameters of a session.

    Parameters
    ----------
    session : calibrator.session.Session
    options : Options

    Returns
    -------
    Result

    Raises
    ------
    IdentifiabilityError
        Too few poses for the free parameters, or a bad option.
    """
    if options.method not in METHODS:
        raise IdentifiabilityError(f"unknown method {options.method!r}; use one of {METHODS}")
    meta = session.meta
    obs = session.observations
    k = DEFAULT_K if options.k is None else float(options.k)
    if k < 0:
        raise IdentifiabilityError(f"orientation weight k must be >= 0, got {k}")
    k = k if obs.has_orientation else 0.0
    tool_known = meta.tool_known if options.tool_known is None else options.tool_known
    fit_idx, val_idx = split(len(obs), options.validation_fraction, options.seed)
    fit, val = obs.subset(fit_idx), obs.subset(val_idx)
    if len(fit) < 3:
        raise IdentifiabilityError(
            f"{len(fit)} fitting pose{'' if len(fit) == 1 else 's'}: at least 3 are needed"
        )

    base0, tool0 = initial.first_guess(
        meta.nominal_mdh, fit, meta.flange2tool, meta.frame, tool_known
    )
    candidates, dropped = parameters.structural_candidates(meta.nominal_mdh, meta.frame, tool_known)
    space = parameters.ParameterSpace(meta.nominal_mdh, base0, tool0, candidates)
    # What the model itself cannot separate (any poses), then what these
    # poses cannot: too few poses is an error, not a reason to drop.
    generic = measurement.Observations(*_generic_poses(space, fit.has_orientation))
    jac = measurement.jacobian(space, np.zeros(space.size), generic, k, names=candidates)
    kept, redundant = parameters.prune(candidates, jac, context="(for any poses)")
    rows = len(fit) * (6 if measurement.uses_orientation(fit, k) else 3)
    parameters.require_enough(rows, len(kept), f"{len(fit)} fitting poses")
    jac = measurement.jacobian(space.with_free(kept), np.zeros(len(kept)), fit, k)
    kept, weak = parameters.prune(kept, jac, context="with these poses")
    space = space.with_free(kept)
    dropped += redundant + weak

    zero = np.zeros(space.size)
    x = zero
    details = {}
    if options.method in ("pso", "hybrid"):
        lower, upper = space.bounds()
        swarm = objective.SwarmObjective(space, fit, k)
        found = pso.ipso(
            swarm,
            lower,
            upper,
            particles=options.particles,
            generations=options.generations,
            seed=options.seed,
            on_generation=options.on_generation,
        )
        x = found.x
        details["pso"] = {
            "objective": found.f,
            "particles": options.particles,
            "generations": options.generations,
        }
        keep = np.unique(
            np.linspace(0, len(found.history) - 1, CONVERGENCE_POINTS).round().astype(int)
        )
        details["convergence"] = [[int(g), float(found.history[g])] for g in keep]
    if options.method in ("lm", "hybrid"):
        refined = refine.refine(space, fit, x, k)
        x = refined.x
        details["least_squares"] = {
            "objective": refined.cost,
            "evaluations": refined.evaluations,
            "message": refined.message,
        }

    stats = {
        part: {
            "before": report.error_stats(space, zero, o),
            "after": report.error_stats(space, x, o),
        }
        for part, o in (("fit", fit), ("validation", val))
    }
    return Result(space, x, dropped, stats, options, k, fit_idx, val_idx, details)


def _generic_poses(space, orientation, n=64):
    """Well-spread poses of the nominal arm, to tell the model's redundancies.

    Returns
    -------
    q : ndarray, shape (n, 6)
    points : ndarray, shape (n, 3)
    rotations : ndarray, shape (n, 3, 3) or None
    """
    q = np.random.default_rng(0).uniform(-np.pi, np.pi, (n, 6))
    pose = measurement.predict(space, np.zeros(space.size), q)
    return q, pose[:, :3, 3], pose[:, :3, :3] if orientation else None
