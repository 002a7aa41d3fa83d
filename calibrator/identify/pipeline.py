"""``identify``: from a session to identified parameters and their accuracy.

The steps of the method, each in its own module: split the poses (fit /
held out), closed-form first guess of the frames (:mod:`.initial`), the free
set (:mod:`.freeset`: structure, the model's redundancy, what these poses
pin down), the fit under the chosen loss (:mod:`.fitters`, one table of
steps over a :class:`~.problem.Problem`), then outliers, uncertainty
(:mod:`.uncertainty`) and the before/after statistics (:mod:`.report`).
"""

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from calibrator import recorded_options
from calibrator.errors import IdentifiabilityError
from calibrator.fit_records import FitStats, SolverDetails, Uncertainty
from calibrator.identify import (
    accuracy,
    fitters,
    freeset,
    identifiability,
    initial,
    robust,
    uncertainty,
)
from calibrator.identify.problem import Problem
from calibrator.inputs.errors import StrictError
from calibrator.model import measurement, parameters, plausibility
from calibrator.recorded_options import Options

if TYPE_CHECKING:
    from calibrator.session import Session

METHODS = recorded_options.METHODS
LOSSES = recorded_options.LOSSES
#: Default orientation weight (mm^2/rad^2), :data:`calibrator.recorded_options.DEFAULT_K`.
DEFAULT_K = recorded_options.DEFAULT_K
#: Largest session ``identify`` takes. Memory and time grow linearly with
#: the poses (about 10 kB and 0.1 ms of CPU per pose, least squares and uncertainty);
#: beyond this, thin the session (more poses than this add nothing a
#: well-spread subset does not give).
MAX_POSES = recorded_options.MAX_POSES
#: A residual noise above this multiple of ``Options.noise_mm`` gives a warning.
NOISE_WARNING = 2.0
#: Most points of the swarm's convergence curve kept in ``details``.
CONVERGENCE_POINTS = fitters.CONVERGENCE_POINTS


@dataclass(frozen=True)
class Result:
    """Everything ``identify`` found, ready for calibration.json (derive with ``replace()``).

    ``dropped`` the ``{"name", "reason"}`` of each candidate left out;
    ``stats`` the before/after statistics (:class:`calibrator.fit_records.FitStats`);
    ``details`` what the fitters reported (:class:`calibrator.fit_records.SolverDetails`);
    ``warnings`` are sentences about the session (redundancy, duplicates,
    conditioning, suspected outliers); ``outliers`` the pose numbers a
    robust loss set aside (or, with ``lsq``, flagged); ``uncertainty``
    :func:`calibrator.identify.uncertainty.analyse` (:class:`calibrator.fit_records.Uncertainty`).
    """

    space: parameters.ParameterSpace
    x: np.ndarray
    dropped: list[dict[str, str]]
    stats: FitStats
    options: Options
    k: float
    fit_index: np.ndarray
    validation_index: np.ndarray
    details: SolverDetails = field(default_factory=lambda: SolverDetails())
    warnings: list[str] = field(default_factory=list)
    outliers: list[int] = field(default_factory=list)
    uncertainty: Uncertainty = field(default_factory=lambda: Uncertainty())
    tool_known: bool = False

    @property
    def mdh(self) -> np.ndarray:
        """Identified MDH table, shape (6, 5)."""
        return self.space.unpack(self.x)[0]

    @property
    def base2tracker(self) -> np.ndarray:
        return self.space.unpack(self.x)[1]

    @property
    def flange2tool(self) -> np.ndarray:
        return self.space.unpack(self.x)[2]

    @property
    def loss(self) -> str:
        return self.options.loss


def split(n_poses: int, fraction: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
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


def identify(
    session: "Session",
    options: Options | None = None,
    *,
    on_generation: Callable[[int, float], None] | None = None,
    progress: Callable[[str], None] | None = None,
) -> Result:
    """Identify the free parameters of a session.

    Parameters
    ----------
    session : calibrator.session.Session
    options : calibrator.recorded_options.Options, optional
        Default: the command's defaults. What each may be: its rule (checked here).
    on_generation : callable, optional
        ``on_generation(generation, best_cost)`` after each swarm generation
        (progress displays).
    progress : callable, optional
        ``progress(text)`` at each stage.

    Returns
    -------
    Result

    Raises
    ------
    IdentifiabilityError
        Too many or too few poses, nothing identifiable, or a bad option.
    """
    options = Options() if options is None else options
    _check_options(options)
    say = progress or (lambda text: None)
    meta, obs = session.meta, session.observations
    _check_size(len(obs))
    pose_numbers = _pose_numbers(session, len(obs))
    k = (DEFAULT_K if options.k is None else float(options.k)) if obs.has_orientation else 0.0
    tool_known = meta.tool_known if options.tool_known is None else options.tool_known
    fit_idx, val_idx = split(len(obs), options.validation_fraction, options.seed)
    fit, val = obs.subset(fit_idx), obs.subset(val_idx)
    duplicates = _check_fitting_poses(fit)

    say(f"first guess of the frames from {len(fit)} poses")
    base0, tool0 = initial.first_guess(
        meta.nominal_mdh, fit, meta.flange2tool, meta.frame, tool_known
    )
    say(f"what {len(fit)} poses can identify")
    orientation = measurement.uses_orientation(fit, k)
    free = freeset.decide(
        meta.nominal_mdh,
        meta.frame,
        tool_known,
        orientation,
        base0=base0,
        tool0=tool0,
        k=k,
        fit=fit,
        noise_mm=options.noise_mm,
    )
    problem = Problem.of(free.space, fit, k)
    assert free.information is not None  # decide() always measures the kept set
    cond = identifiability.condition_number(free.information)
    warnings = identifiability.session_warnings(problem.rows, len(free.names), cond, duplicates)

    found, solver = fitters.fit(problem, options.loss, _settings(options, say, on_generation))
    x = found.x
    # A fit can absorb a unit or model mistake into huge deltas: refuse or warn.
    warnings += plausibility.check_deltas(meta.nominal_mdh, problem.space.unpack(x)[0])
    # Points in the tracker frame: the outlier test whitens along each pose's beam.
    beams = robust.beam_axes(fit.points) if meta.frame == "tracker" else None
    outlier_idx, inliers, doubts = _outliers(problem, found, options.loss, beams)
    if len(doubts):
        warnings.append(
            f"pose(s) {_names(pose_numbers[fit_idx[doubts]])} fit far worse than the "
            "rest (possible outliers); consider --loss huber or trimmed"
        )

    say("uncertainty")
    # Joint parameters these poses left out: their prior enters the prediction.
    unidentified = [d["name"] for d in free.dropped if "with these poses" in d["reason"]]
    unc = uncertainty.analyse(inliers, x, val, unidentified)
    # Held-out poses beyond the fitted joint ranges: the model is extrapolated there.
    warnings += uncertainty.range_warnings(fit.q, val.q)
    warnings += _noise_warning(unc, options.noise_mm)
    stats = accuracy.fit_stats(problem.space, x, fit, val)
    return Result(
        problem.space,
        x,
        free.dropped,
        stats,
        options,
        problem.k,
        fit_idx,
        val_idx,
        solver,
        warnings,
        [int(p) for p in pose_numbers[fit_idx[outlier_idx]]],
        unc,
        bool(tool_known),
    )


def _check_size(n_poses):
    if n_poses > MAX_POSES:
        raise IdentifiabilityError(
            f"the session has {n_poses} poses; identify takes at most {MAX_POSES} "
            "(thin it, e.g. keep every n-th pose: a well-spread subset identifies as well)"
        )


def _check_fitting_poses(fit):
    """Refuse fewer than 3 distinct fitting poses; returns the indices of repeats."""
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
    return duplicates


def _settings(options, say, on_generation):
    return fitters.Settings(
        options.method,
        options.particles,
        options.generations,
        options.swarm_poses,
        options.seed,
        on_generation,
        say,
    )


def _outliers(problem, found, loss, beams=None):
    """Outlier poses, the inlier problem, and poses to warn about (indices into the fit).

    A robust loss sets its outliers aside; ``lsq`` and ``minimax`` set nothing
    aside but name the poses that fit far worse (``lsq`` records them too).
    """
    if loss not in ("lsq", "minimax"):
        keep = np.setdiff1d(np.arange(len(problem)), found.outliers)
        return found.outliers, problem.subset(keep), np.array([], dtype=int)
    suspects = _suspects(problem, found.x, beams)
    return (suspects if loss == "lsq" else found.outliers), problem, suspects


def _suspects(problem, x, beams=None):
    """Fitting poses that fit far worse than the rest (indices), for lsq and minimax."""
    # Without redundancy the residuals are too few and too small to judge poses by.
    if problem.rows < identifiability.MIN_VALUES_PER_PARAMETER * problem.space.size:
        return np.array([], dtype=int)
    res = problem.residuals(x)
    return robust.outliers(res, len(problem), jacobian=problem.jacobian(x), beams=beams)


def _noise_warning(unc, noise_mm):
    sigma = unc["residual_sigma"]["position_mm"]
    if sigma <= NOISE_WARNING * noise_mm:
        return []
    return [
        f"the fit's residual noise {sigma:.3g} mm per axis is over {NOISE_WARNING:g} times "
        f"the {noise_mm:g} mm assumed when choosing the free parameters; "
        f"rerun with --noise-mm {sigma:.2g} to judge them against it"
    ]


def _check_options(options):
    try:
        options.check()
    except StrictError as exc:
        raise IdentifiabilityError(str(exc)) from None


def _pose_numbers(session, n):
    table = getattr(session, "table", None)
    if table is not None and "pose" in table.column_names:
        # Through a list: pyarrow's numpy conversion imports pandas (a third of a second).
        return np.array(table["pose"].to_pylist(), dtype=np.int64)
    return np.arange(n)


def _names(numbers, limit=8):
    text = ", ".join(str(int(p)) for p in numbers[:limit])
    return text + (f" and {len(numbers) - limit} more" if len(numbers) > limit else "")
