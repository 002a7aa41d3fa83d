"""The fit of a :class:`~calibrator.identify.problem.Problem` under a loss: one table of steps.

:data:`STEPS` names, for each ``(loss, method)``, the fitters run one after
the other, each starting from the previous one's deltas:

=========  ==============================  ==========================  =====================
loss       hybrid                          pso                         lm
=========  ==============================  ==========================  =====================
lsq        swarm, least squares            swarm                       least squares
huber      swarm, least squares, huber     swarm, least squares, huber least squares, huber
trimmed    swarm, least squares, trimmed   swarm, least squares, ...   least squares, trimmed
minimax    least squares, minimax swarm    minimax swarm               least squares,
           (around it), minimax                                        minimax
=========  ==============================  ==========================  =====================

What the swarm sees: for ``lsq``, ``huber`` and ``trimmed`` the swarm only
has to bring the fit into the basin of the local solver, so it sees at most
``swarm_poses`` fitting poses (a seeded random subset); the local solver
then judges every fitting pose. For ``minimax`` the swarm sees the
``swarm_poses`` poses worst at its start (they decide the maximum), and the
epigraph refinement checks every pose.

Every step returns a :class:`~calibrator.identify.problem.FitResult`.
"""

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from calibrator.fit_records import SolverDetails, StepInfo
from calibrator.identify import minimax, pso, refine, robust
from calibrator.identify.problem import FitResult, Problem

#: Most points of the swarm's convergence curve kept for calibration.json.
CONVERGENCE_POINTS = 500


@dataclass(frozen=True)
class Settings:
    """What the steps need beyond the problem: swarm size, seed, progress hooks."""

    method: str
    particles: int
    generations: int
    swarm_poses: int
    seed: int
    on_generation: Callable | None = None
    say: Callable[[str], None] = lambda text: None


def swarm(problem: Problem, x: np.ndarray, settings: Settings) -> FitResult:
    """IPSO on the sum of squares over a seeded subset of the fitting poses."""
    sub = problem
    if len(problem) > settings.swarm_poses:
        rng = np.random.default_rng(settings.seed)
        pick = rng.choice(len(problem), settings.swarm_poses, replace=False)
        sub = problem.subset(np.sort(pick))
    lower, upper = problem.space.bounds()
    return _ipso(sub, lower, upper, settings, "lsq")


def minimax_swarm(problem: Problem, x: np.ndarray, settings: Settings) -> FitResult:
    """IPSO on the worst pose's error, over the poses worst at ``x``.

    After least squares (hybrid) the box is a quarter of the swarm's box
    around ``x``, and the swarm's answer is kept only if it lowers the worst
    error over every fitting pose; alone (pso) the box is the full one.
    """
    worst = np.argsort(-problem.pose_errors(x))[: settings.swarm_poses]
    half = 0.25 * problem.space.bounds()[1]
    alone = settings.method == "pso"
    lower, upper = (-4 * half, 4 * half) if alone else (x - half, x + half)
    found = _ipso(problem.subset(np.sort(worst)), lower, upper, settings, "minimax")
    if alone or np.max(problem.pose_errors(found.x)) < np.max(problem.pose_errors(x)):
        return found
    return replace(found, x=x, message="kept the start: the swarm did not lower the worst error")


def _on_every_pose(what: str, run: Callable[[Problem, np.ndarray], FitResult]) -> Callable:
    """A step running a local fitter on every fitting pose, saying so first."""

    def step(problem: Problem, x: np.ndarray, settings: Settings) -> FitResult:
        settings.say(f"{what} on {len(problem)} poses")
        return run(problem, x)

    step.__doc__ = f"{what[0].upper()}{what[1:]} on every fitting pose."
    return step


#: Levenberg-Marquardt; Huber M-estimate; trimmed least squares; SLSQP in epigraph form.
least_squares = _on_every_pose("least squares", refine.refine)
huber = _on_every_pose("Huber fit", robust.huber)
trimmed = _on_every_pose("trimmed least squares", robust.trimmed)
minimax_refine = _on_every_pose("minimax refinement (SLSQP, epigraph form)", minimax.refine_minimax)


#: A step's key in ``solver``.
StepName = Literal["pso", "least_squares", "robust", "minimax"]
#: (loss, method) -> the steps, in order; each step's name is its key in ``solver``.
STEPS: dict[tuple[str, str], tuple[tuple[StepName, Callable], ...]] = {}
STEPS[("lsq", "hybrid")] = (("pso", swarm), ("least_squares", least_squares))
STEPS[("lsq", "pso")] = (("pso", swarm),)
STEPS[("lsq", "lm")] = (("least_squares", least_squares),)
for _loss, _robust in (("huber", huber), ("trimmed", trimmed)):
    # A robust fit starts from least squares, whatever brought it near.
    _local: tuple[tuple[StepName, Callable], ...] = (
        ("least_squares", least_squares),
        ("robust", _robust),
    )
    STEPS[(_loss, "hybrid")] = (("pso", swarm), *_local)
    STEPS[(_loss, "pso")] = (("pso", swarm), *_local)
    STEPS[(_loss, "lm")] = _local
STEPS[("minimax", "hybrid")] = (
    ("least_squares", least_squares),
    ("pso", minimax_swarm),
    ("minimax", minimax_refine),
)
STEPS[("minimax", "pso")] = (("pso", minimax_swarm),)
STEPS[("minimax", "lm")] = (("least_squares", least_squares), ("minimax", minimax_refine))


def fit(problem: Problem, loss: str, settings: Settings) -> tuple[FitResult, SolverDetails]:
    """Run the steps of ``(loss, settings.method)`` from the first guess.

    Returns
    -------
    last : FitResult
        The last step's result (its ``x`` is the fit; its ``outliers``
        those of a robust loss).
    solver : SolverDetails
        calibration.json's ``solver``: ``loss``, each step's record under
        its name, and the swarm's ``convergence`` (``[[generation, best
        cost], ...]``, at most :data:`CONVERGENCE_POINTS`).
    """
    solver = SolverDetails(loss=loss)
    x = problem.zero()
    last = FitResult(x, float("nan"), 0)
    for name, step in STEPS[(loss, settings.method)]:
        last = step(problem, x, settings)
        x = last.x
        solver[name] = last.record()
        if last.history is not None:
            history = last.history
            keep = np.linspace(0, len(history) - 1, CONVERGENCE_POINTS).round().astype(int)
            solver["convergence"] = [[int(g), float(history[g])] for g in np.unique(keep)]
    return last, solver


def _ipso(sub: Problem, lower, upper, settings: Settings, loss: str) -> FitResult:
    settings.say(
        f"swarm: {settings.particles} particles x {settings.generations} generations "
        f"on {len(sub)} poses ({loss})"
    )
    found = pso.ipso(
        sub.swarm_objective(loss),
        lower,
        upper,
        particles=settings.particles,
        generations=settings.generations,
        seed=settings.seed,
        on_generation=settings.on_generation,
    )
    info = StepInfo(
        particles=settings.particles,
        generations=settings.generations,
        poses=len(sub),
        loss=loss,
    )
    evaluations = settings.particles * (settings.generations + 1)
    return FitResult(found.x, found.f, evaluations, "", history=found.history, info=info)
