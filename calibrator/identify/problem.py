"""What is being fitted: a :class:`Problem` (parameters, poses, weights) and a :class:`FitResult`.

A problem is decided once and then only read: the parameter space (which
deltas are free, around which first guess), the fitting observations and
the orientation weight ``k``, resolved here to 0 when the poses carry no
orientation. Every fitter, the uncertainty analysis and the free-set
decision evaluate the model through it::

    problem = Problem.of(space, fit_obs, k)
    problem.residuals(x)          # (3N,) or (6N,): mm, then sqrt(k) * rad
    problem.jacobian(x)           # (rows, space.size)
    problem.pose_errors(x)        # (N,) squared error per pose, mm^2
    problem.swarm_objective("lsq")  # f(X) for a swarm, (P, D) -> (P,)

Extra parameter blocks (joint error terms on ``q``) belong in the space and
in :meth:`Problem.residuals` / :meth:`Problem.jacobian`: nothing else
evaluates the model.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from calibrator.fit_records import StepInfo, StepRecord
from calibrator.identify import objective
from calibrator.model import measurement, parameters


@dataclass(frozen=True)
class Problem:
    """A fit: parameter space, fitting observations and the resolved orientation weight.

    Attributes
    ----------
    space : calibrator.model.parameters.ParameterSpace
        Free parameters and the first guesses they are deltas from.
    obs : calibrator.model.measurement.Observations
        Fitting poses (tracker or base frame, mm and rad).
    k : float
        Orientation weight (mm^2/rad^2); 0 when the poses have no orientation.
    """

    space: parameters.ParameterSpace
    obs: measurement.Observations
    k: float = 0.0

    @classmethod
    def of(
        cls, space: parameters.ParameterSpace, obs: measurement.Observations, k: float
    ) -> Problem:
        """The problem with ``k`` resolved: 0 unless the poses carry orientation."""
        return cls(space, obs, float(k) if measurement.uses_orientation(obs, k) else 0.0)

    @property
    def orientation(self) -> bool:
        """Whether orientation rows take part."""
        return self.k > 0

    @property
    def rows(self) -> int:
        """Number of residual rows (3 per pose, 6 with orientation)."""
        return len(self.obs) * (6 if self.orientation else 3)

    def __len__(self) -> int:
        return len(self.obs)

    def zero(self) -> np.ndarray:
        """Deltas of the first guess, shape (space.size,)."""
        return np.zeros(self.space.size)

    def subset(self, index: np.ndarray) -> Problem:
        """The same problem on the poses at ``index`` (int array or mask)."""
        return Problem(self.space, self.obs.subset(index), self.k)

    def with_free(self, names: Iterable[str]) -> Problem:
        """The same poses and weights with another free set."""
        return Problem(self.space.with_free(names), self.obs, self.k)

    def residuals(self, x: np.ndarray) -> np.ndarray:
        """Residuals at ``x``, shape (3N,) or (6N,): position (mm), then weighted orientation."""
        return measurement.residuals(self.space, x, self.obs, self.k)

    def jacobian(self, x: np.ndarray, names: Sequence[str] | None = None) -> np.ndarray:
        """Jacobian of :meth:`residuals`, shape (rows, len(names or space.free))."""
        return measurement.jacobian(self.space, x, self.obs, self.k, names=names)

    def pose_errors(self, x: np.ndarray) -> np.ndarray:
        """Squared error per pose ``|dp|^2 + k |delta|^2``, shape (N,) (mm^2)."""
        res = self.residuals(x)
        return (res**2).reshape(-1, len(self.obs), 3).sum(axis=(0, 2))

    def errors(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Position (N, 3) mm and orientation (N, 3) rad or None, model minus measured."""
        return measurement.errors(self.space, x, self.obs)

    def swarm_objective(self, loss: str = "lsq") -> objective.SwarmObjective:
        """``f(X)`` for a swarm, shape (P, D) -> (P,): sum over poses, or the worst (minimax)."""
        return objective.SwarmObjective(self.space, self.obs, self.k, loss)


@dataclass(frozen=True)
class FitResult:
    """What every fitter returns.

    Attributes
    ----------
    x : ndarray, shape (D,)
        Deltas found.
    cost : float
        The fitter's objective there (mm^2: sum of squares, or the worst
        pose's squared error for minimax; robust losses: the plain sum of
        squares over all fitting poses).
    evaluations : int
        Objective or residual evaluations (swarm: particles x generations).
    message : str
        Why the fitter stopped.
    outliers : ndarray of int
        Indices into the fitting poses that a robust fit set aside.
    history : ndarray or None
        Swarm only: best cost after the initial swarm and each generation.
    info : StepInfo
        Fitter-specific numbers for calibration.json's ``solver`` entry.
    """

    x: np.ndarray
    cost: float
    evaluations: int
    message: str = ""
    outliers: np.ndarray = field(default_factory=lambda: np.array([], dtype=int))
    history: np.ndarray | None = None
    info: StepInfo = field(default_factory=lambda: StepInfo())

    def record(self) -> StepRecord:
        """This step's JSON record: ``objective``, ``evaluations``, ``message``, ``info``."""
        out = StepRecord(objective=float(self.cost), evaluations=int(self.evaluations))
        if self.message:
            out["message"] = self.message
        out.update(self.info)
        return out
