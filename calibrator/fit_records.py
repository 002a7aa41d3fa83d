"""Typed records of an identification: statistics, uncertainty and solver entries.

These are the shapes of the ``stats``, ``uncertainty`` and ``solver`` keys of
calibration.json (``docs/calibration-format.md``). They are
:class:`typing.TypedDict`: at run time plain dicts, so a document is written
exactly as before and any file a user has (older ones with fewer keys
included) reads into them; the type checker sees every key and its type.
Keys a file may lack are not required (``total=False``); readers of a loaded
file use ``.get`` for them.

Units are in the key names where a key holds a quantity (``_mm``, ``_deg``,
``_rad``); the docstrings give the rest. They sit beside
:mod:`calibrator.calibration` (the documents' layer), below ``identify``,
which fills them.
"""

from __future__ import annotations

from typing import NotRequired, TypedDict


class Summary(TypedDict):
    """Mean, sample standard deviation and largest value of one error (its unit: the key's)."""

    mean: float
    std: float
    max: float


class AxesSummary(TypedDict):
    """A :class:`Summary` per tracker axis (deg: absolute rotation error components)."""

    x: Summary
    y: Summary
    z: Summary


class ErrorStats(TypedDict):
    """Errors of one parameter set on some poses (:func:`calibrator.identify.accuracy.error_stats`).

    Attributes
    ----------
    n : int
        Poses; ``0`` alone when there were none.
    position_mm : Summary
        Distance between model and measured point (mm).
    orientation_deg : AxesSummary
        With orientation data: the rotation error about each tracker axis (deg).
    """

    n: int
    position_mm: NotRequired[Summary]
    orientation_deg: NotRequired[AxesSummary]


class BeforeAfter(TypedDict):
    """:class:`ErrorStats` at the first guess (``before``) and at the fit (``after``)."""

    before: ErrorStats
    after: ErrorStats


class FitStats(TypedDict, total=False):
    """calibration.json's ``stats``: on the fitted and on the held-out poses.

    Empty in a file written before statistics were recorded.
    """

    fit: BeforeAfter
    validation: BeforeAfter


class ResidualSigma(TypedDict):
    """Residual noise of the fit: ``position_mm`` per axis (mm), ``orientation_rad`` or None."""

    position_mm: float
    orientation_rad: float | None


class Correlation(TypedDict):
    """Correlation matrix of the free parameters: ``names`` (P,), ``matrix`` (P, P), rounded."""

    names: list[str]
    matrix: list[list[float]]


class CorrelatedPair(TypedDict):
    """Two free parameters ``a`` and ``b`` whose correlation ``r`` is strong (-1..1)."""

    a: str
    b: str
    r: float


class Prediction(TypedDict):
    """Predicted position error at held-out poses (:func:`.uncertainty.predict_error`).

    Attributes
    ----------
    model_rms_mean, model_rms_max : float
        RMS position error the parameters' uncertainty alone causes, mean and
        worst over the poses (mm).
    error_mean : float
        Expected mean distance between model and measured point, noise included (mm).
    noise_floor : float
        Mean distance the residual noise alone gives (mm).
    """

    model_rms_mean: float
    model_rms_max: float
    error_mean: float
    noise_floor: float


class Uncertainty(TypedDict, total=False):
    """calibration.json's ``uncertainty`` (:func:`calibrator.identify.uncertainty.analyse`).

    Empty in a file written before it was recorded.

    Attributes
    ----------
    standard_errors : dict
        ``{name: standard error}`` of each free parameter (mm, rad; joint
        terms in their own units).
    correlation : Correlation
    strong_correlations : list of CorrelatedPair
        Strongest first.
    residual_sigma : ResidualSigma
    position_dof : float
        Residual degrees of freedom of the position rows.
    predicted_validation_mm : Prediction
        With held-out poses.
    """

    standard_errors: dict[str, float]
    correlation: Correlation
    strong_correlations: list[CorrelatedPair]
    residual_sigma: ResidualSigma
    position_dof: float
    predicted_validation_mm: Prediction


class StepInfo(TypedDict, total=False):
    """Numbers one fitter adds to its :class:`StepRecord`.

    Attributes
    ----------
    particles, generations, poses : int
        The swarm's size, generations and fitting poses.
    loss : str
        The swarm's loss.
    worst_mm : float
        Minimax: the worst pose's error (mm).
    iterations : int
        Minimax: SLSQP iterations.
    outliers : int
        Robust losses: poses set aside.
    """

    particles: int
    generations: int
    poses: int
    loss: str
    worst_mm: float
    iterations: int
    outliers: int


class StepRecord(StepInfo):
    """One fitter's entry in ``solver`` (:meth:`calibrator.identify.problem.FitResult.record`).

    Attributes
    ----------
    objective : float
        The fitter's objective at its solution (mm^2).
    evaluations : int
        Objective or residual evaluations.
    message : str
        Why it stopped (when it said).
    """

    objective: float
    evaluations: int
    message: NotRequired[str]


class SolverDetails(TypedDict, total=False):
    """calibration.json's ``solver``: what each fitter reported.

    Attributes
    ----------
    loss : str
    pso, least_squares, robust, minimax : StepRecord
        The steps that ran (:data:`calibrator.identify.fitters.STEPS`).
    convergence : list
        The swarm's ``[[generation, best cost (mm^2)], ...]``.
    joint_terms : dict
        The joint-term decisions (:func:`calibrator.identify.joint_fit.run`).
    """

    loss: str
    pso: StepRecord
    least_squares: StepRecord
    robust: StepRecord
    minimax: StepRecord
    convergence: list[list[float]]
    joint_terms: dict[str, object]
