"""``identify``: from a session to identified parameters and their accuracy.

Stages: split the poses (fit / held out), closed-form first guess of the
frames, the free set (structure, model redundancy, then what these poses
can pin down), the fit under the chosen loss, then uncertainty and the
before/after statistics.

What the swarm sees: for ``lsq``, ``huber`` and ``trimmed`` the swarm only
has to bring the fit into the basin of the local solver, so it sees at most
:data:`SWARM_POSES` fitting poses (a seeded random subset); the local solver
then judges every fitting pose. For ``minimax`` the swarm sees the
:data:`SWARM_POSES` poses worst under the least-squares fit (they decide the
maximum), and the epigraph refinement checks every pose.
"""

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from calibrator import measurement, parameters, plausibility
from calibrator.errors import IdentifiabilityError
from calibrator.identify import (
    identifiability,
    initial,
    minimax,
    objective,
    pso,
    refine,
    report,
    robust,
    uncertainty,
)

METHODS = ("hybrid", "pso", "lm")
LOSSES = ("lsq", "huber", "trimmed", "minimax")
#: Default orientation weight (mm^2/rad^2): 1 mrad weighs as 0.1 mm, about
#: the ratio of a 6-DoF probe's angular noise to a tracker's point noise.
DEFAULT_K = 1.0e4
#: Largest session ``identify`` takes. Memory and time grow linearly with
#: the poses (about 10 kB and 0.1 ms of CPU per pose, least squares and uncertainty);
#: beyond this, thin the session (more poses than this add nothing a
#: well-spread subset does not give).
MAX_POSES = 50_000
#: Most fitting poses the swarm sees (see the module docstring).
SWARM_POSES = 32
#: A residual noise above this multiple of ``Options.noise_mm`` gives a warning.
NOISE_WARNING = 2.0
#: Most points of the swarm's convergence curve kept in ``details``.
CONVERGENCE_POINTS = 500


@dataclass(frozen=True)
class Options:
    """Settings of one identification (CLI flags of ``calibrator identify``).

    ``noise_mm`` is the measurement noise assumed when deciding what these
    poses can identify (one residual row, mm; orientation rows count in
    their ``sqrt(k)`` weighted units). ``on_generation(generation,
    best_cost)`` is called after each swarm generation and ``progress(text)``
    at each stage, for progress displays.
    """

    method: str = "hybrid"
    particles: int = 20
    generations: int = 2000
    k: float | None = None
    validation_fraction: float = 0.2
    seed: int = 0
    tool_known: bool | None = None
    loss: str = "lsq"
    noise_mm: float = 0.05
    swarm_poses: int = SWARM_POSES
    on_generation: Callable | None = field(default=None, compare=False)
    progress: Callable | None = field(default=None, compare=False)


@dataclass
class Result:
    """Everything ``identify`` found, ready for calibration.json.

    ``warnings`` are sentences about the session (redundancy, duplicates,
    conditioning, suspected outliers); ``outliers`` the pose numbers a
    robust loss set aside (or, with ``lsq``, flagged); ``uncertainty`` the
    dict of :func:`calibrator.identify.uncertainty.analyse`.
    """

    space: parameters.ParameterSpace
    x: np.ndarray
    dropped: list
    stats: dict
    options: Options
    k: float
    fit_index: np.ndarray
    validation_index: np.ndarray
    details: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    outliers: list = field(default_factory=list)
    uncertainty: dict = field(default_factory=dict)

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

    @property
    def loss(self):
        return self.options.loss


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
        Too many or too few poses, nothing identifiable, or a bad option.
    """
    _check_options(options)
    say = options.progress or (lambda text: None)
    meta = session.meta
    obs = session.observations
    if len(obs) > MAX_POSES:
        raise IdentifiabilityError(
            f"the session has {len(obs)} poses; identify takes at most {MAX_POSES} "
            "(thin it, e.g. keep every n-th pose: a well-spread subset identifies as well)"
        )
    pose_numbers = _pose_numbers(session, len(obs))
    k = DEFAULT_K if options.k is None else float(options.k)
    k = k if obs.has_orientation else 0.0
    tool_known = meta.tool_known if options.tool_known is None else options.tool_known
    fit_idx, val_idx = split(len(obs), options.validation_fraction, options.seed)
    fit, val = obs.subset(fit_idx), obs.subset(val_idx)
    if len(fit) < 3:
        raise IdentifiabilityError(
            f"{len(fit)} fitting pose{'' if len(fit) == 1 else 's'}: at least 3 are needed"
        )
    duplicates = identifiability.duplicate_poses(fit.q)
    if len(fit) - len(duplicates) < 3:
        raise IdentifiabilityError(
            f"only {len(fit) - len(duplicates)} distinct fitting poses among {len(fit)}: "
            "measure distinct, well-spread poses"
        )

    say(f"first guess of the frames from {len(fit)} poses")
    base0, tool0 = initial.first_guess(
        meta.nominal_mdh, fit, meta.flange2tool, meta.frame, tool_known
    )
    orientation = measurement.uses_orientation(fit, k)
    candidates, dropped = parameters.structural_candidates(
        meta.nominal_mdh, meta.frame, tool_known, orientation
    )
    space = parameters.ParameterSpace(meta.nominal_mdh, base0, tool0, candidates)
    # What the model itself cannot separate (any poses), then what these
    # poses cannot pin down: too few poses is an error, not a reason to drop.
    generic = measurement.Observations(*_generic_poses(space, fit.has_orientation))
    jac = measurement.jacobian(space, np.zeros(space.size), generic, k, names=candidates)
    kept, redundant = parameters.prune(candidates, jac, context="(for any poses)")
    rows = len(fit) * (6 if orientation else 3)
    parameters.require_enough(rows, len(kept), f"{len(fit)} fitting poses")
    say(f"what {len(fit)} poses can identify")
    before = kept
    jac = identifiability.jacobian_on(space.with_free(kept), kept, fit, k)
    kept, weak = identifiability.select(kept, jac, options.noise_mm)
    identifiability.require_some(kept)
    space = space.with_free(kept)
    dropped += redundant + weak
    info = identifiability.scaled_information(
        jac[:, [before.index(n) for n in space.free]], space.free, options.noise_mm
    )
    warnings = identifiability.session_warnings(
        rows, space.size, identifiability.condition_number(info), duplicates
    )

    x, details, outlier_idx = _fit(space, fit, k, options, say)
    # A fit can absorb a unit or model mistake into huge deltas: refuse or warn.
    warnings += plausibility.check_deltas(meta.nominal_mdh, space.unpack(x)[0])
    inliers = fit.subset(np.setdiff1d(np.arange(len(fit)), outlier_idx))
    if options.loss in ("lsq", "minimax"):
        suspects = np.array([], dtype=int)
        # Without redundancy the residuals are too few and too small to judge poses by.
        if rows >= identifiability.MIN_VALUES_PER_PARAMETER * space.size:
            res = measurement.residuals(space, x, fit, k)
            suspects = robust.outliers(res, len(fit), robust.robust_scales(res, len(fit)))
        if len(suspects):
            warnings.append(
                f"pose(s) {_names(pose_numbers[fit_idx[suspects]])} fit far worse than the "
                "rest (possible outliers); consider --loss huber or trimmed"
            )
        outlier_idx = suspects if options.loss == "lsq" else outlier_idx
        inliers = fit

    say("uncertainty")
    unc = uncertainty.analyse(space, x, inliers, k, val)
    warnings += uncertainty.range_warnings(fit.q, val.q)  # issue 22: extrapolation
    sigma = unc["residual_sigma"]["position_mm"]
    if sigma > NOISE_WARNING * options.noise_mm:
        warnings.append(
            f"the fit's residual noise {sigma:.3g} mm per axis is over {NOISE_WARNING:g} times "
            f"the {options.noise_mm:g} mm assumed when choosing the free parameters; "
            f"rerun with --noise-mm {sigma:.2g} to judge them against it"
        )
    zero = np.zeros(space.size)
    stats = {
        part: {
            "before": report.error_stats(space, zero, o),
            "after": report.error_stats(space, x, o),
        }
        for part, o in (("fit", fit), ("validation", val))
    }
    return Result(
        space,
        x,
        dropped,
        stats,
        options,
        k,
        fit_idx,
        val_idx,
        details,
        warnings,
        [int(p) for p in pose_numbers[fit_idx[outlier_idx]]],
        unc,
    )


def _check_options(options):
    if options.method not in METHODS:
        raise IdentifiabilityError(f"unknown method {options.method!r}; use one of {METHODS}")
    if options.loss not in LOSSES:
        raise IdentifiabilityError(f"unknown loss {options.loss!r}; use one of {LOSSES}")
    if options.k is not None and not float(options.k) >= 0:
        raise IdentifiabilityError(f"orientation weight k must be >= 0, got {options.k}")
    if not options.noise_mm > 0:
        raise IdentifiabilityError(f"noise_mm must be > 0, got {options.noise_mm}")
    if options.swarm_poses < 1:
        raise IdentifiabilityError(f"swarm_poses must be >= 1, got {options.swarm_poses}")


def _pose_numbers(session, n):
    table = getattr(session, "table", None)
    if table is not None and "pose" in table.column_names:
        # Through a list: pyarrow's numpy conversion imports pandas (a third of a second).
        return np.array(table["pose"].to_pylist(), dtype=np.int64)
    return np.arange(n)


def _names(numbers, limit=8):
    text = ", ".join(str(int(p)) for p in numbers[:limit])
    return text + (f" and {len(numbers) - limit} more" if len(numbers) > limit else "")


def _fit(space, fit, k, options, say):
    """Run the optimisers for ``options.loss``; returns x, details, outlier indices."""
    details = {"loss": options.loss}
    zero = np.zeros(space.size)
    outlier_idx = np.array([], dtype=int)
    rng = np.random.default_rng(options.seed)
    x = zero
    if options.loss == "minimax":
        if options.method in ("lm", "hybrid"):
            say(f"least squares on {len(fit)} poses (start of the minimax fit)")
            x = _least_squares(space, fit, zero, k, details)
        if options.method in ("pso", "hybrid"):
            worst = np.argsort(-minimax.pose_errors(space, x, fit, k))[: options.swarm_poses]
            half = 0.25 * space.bounds()[1]
            lower, upper = (
                (x - half, x + half) if options.method == "hybrid" else (-4 * half, 4 * half)
            )
            found = _swarm(
                space, fit.subset(np.sort(worst)), k, lower, upper, options, details, "minimax", say
            )
            if options.method == "pso" or np.max(
                minimax.pose_errors(space, found, fit, k)
            ) < np.max(minimax.pose_errors(space, x, fit, k)):
                x = found
        if options.method in ("lm", "hybrid"):
            say(f"minimax refinement (SLSQP, epigraph form) on {len(fit)} poses")
            mm = minimax.refine_minimax(space, fit, x, k)
            x = mm.x
            details["minimax"] = {
                "worst_mm": mm.worst,
                "iterations": mm.iterations,
                "message": mm.message,
            }
        return x, details, outlier_idx

    if options.method in ("pso", "hybrid"):
        sub = fit
        if len(fit) > options.swarm_poses:
            sub = fit.subset(np.sort(rng.choice(len(fit), options.swarm_poses, replace=False)))
        lower, upper = space.bounds()
        x = _swarm(space, sub, k, lower, upper, options, details, "lsq", say)
    if options.loss == "lsq" and options.method == "pso":
        return x, details, outlier_idx
    say(f"least squares on {len(fit)} poses")
    x = _least_squares(space, fit, x, k, details)
    if options.loss == "huber":
        say(f"Huber fit on {len(fit)} poses")
        found = robust.huber(space, fit, x, k)
    elif options.loss == "trimmed":
        say(f"trimmed least squares on {len(fit)} poses")
        found = robust.trimmed(space, fit, x, k)
    else:
        return x, details, outlier_idx
    details["robust"] = {"evaluations": found.evaluations, "outliers": len(found.outliers)}
    return found.x, details, found.outliers


def _swarm(space, obs, k, lower, upper, options, details, loss, say):
    say(
        f"swarm: {options.particles} particles x {options.generations} generations "
        f"on {len(obs)} poses ({loss})"
    )
    found = pso.ipso(
        objective.SwarmObjective(space, obs, k, loss),
        lower,
        upper,
        particles=options.particles,
        generations=options.generations,
        seed=options.seed,
        on_generation=options.on_generation,
    )
    history = found.history
    keep = np.unique(np.linspace(0, len(history) - 1, CONVERGENCE_POINTS).round().astype(int))
    details["pso"] = {
        "objective": found.f,
        "particles": options.particles,
        "generations": options.generations,
        "poses": len(obs),
        "loss": loss,
    }
    details["convergence"] = [[int(g), float(history[g])] for g in keep]
    return found.x


def _least_squares(space, obs, x0, k, details):
    refined = refine.refine(space, obs, x0, k)
    details["least_squares"] = {
        "objective": refined.cost,
        "evaluations": refined.evaluations,
        "message": refined.message,
    }
    return refined.x


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
