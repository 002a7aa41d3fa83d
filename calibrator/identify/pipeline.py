"""``identify``: from a session to identified parameters and their accuracy."""

from dataclasses import dataclass, field

import numpy as np

from calibrator import measurement, parameters
from calibrator.errors import IdentifiabilityError
from calibrator.identify import initial, objective, pso, refine, report

METHODS = ("hybrid", "pso", "lm")
#: Default orientation weight (mm^2/rad^2): 1 mrad weighs as 0.1 mm, about
#: the ratio of a 6-DoF probe's angular noise to a tracker's point noise.
DEFAULT_K = 1.0e4


@dataclass(frozen=True)
class Options:
    """Settings of one identification (CLI flags of ``calibrator identify``)."""

    method: str = "hybrid"
    particles: int = 20
    generations: int = 2000
    k: float | None = None
    validation_fraction: float = 0.2
    seed: int = 0
    tool_known: bool | None = None


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
        raise IdentifiabilityError(f"{len(fit)} fitting poses: at least 3 are needed")

    base0, tool0 = initial.first_guess(
        meta.nominal_mdh, fit, meta.flange2tool, meta.frame, tool_known
    )
    candidates, dropped = parameters.structural_candidates(meta.nominal_mdh, meta.frame, tool_known)
    space = parameters.ParameterSpace(meta.nominal_mdh, base0, tool0, candidates)
    zero = np.zeros(space.size)
    jac = measurement.jacobian(space, zero, fit, k, names=candidates)
    parameters.require_enough(jac.shape[0], 1, "fitting poses")
    kept, pruned = parameters.prune(candidates, jac)
    parameters.require_enough(jac.shape[0], len(kept), f"{len(fit)} fitting poses")
    space = space.with_free(kept)

    x = np.zeros(space.size)
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
        )
        x = found.x
        details["pso"] = {
            "objective": found.f,
            "particles": options.particles,
            "generations": options.generations,
        }
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
    return Result(space, x, dropped + pruned, stats, options, k, fit_idx, val_idx, details)
