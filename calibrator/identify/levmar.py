"""Dense Levenberg-Marquardt least squares in numpy: a trust-region method on scaled steps.

Minimises ``|f(x)|^2`` for a residual function ``f`` with an analytic
Jacobian. Written from the algorithm of J. J. More, "The Levenberg-Marquardt
algorithm: implementation and theory" (Numerical Analysis, Lecture Notes in
Mathematics 630, 1978), the method MINPACK's ``lmder`` and therefore
``scipy.optimize.least_squares(method="lm")`` implement, so that it stops at
the same optimum without importing ``scipy.optimize`` (whose package import
costs about half a second of start-up, a third of a whole ``identify`` run).

What it does, per Jacobian ``J`` at the current ``x``:

* scale: ``D = diag(d)`` with ``d_j`` the largest Euclidean norm column
  ``j`` of ``J`` has had so far (More's scaling, MINPACK's ``mode=1``,
  scipy's ``x_scale="jac"``): a parameter in rad and one in mm, or a frame
  offset metres from the origin, then take comparable steps;
* step: the minimiser of ``|J p + f|^2 + lam |D p|^2`` with ``lam >= 0``
  chosen so that ``|D p|`` is within 10 % of the trust radius ``delta``
  (``lam = 0``, the Gauss-Newton step, when that already fits inside).
  The damped systems are solved through one SVD of ``J D^-1`` per
  Jacobian, so each trial ``lam`` costs a few vector operations and a
  rank-deficient ``J`` (a parameter the poses do not move) gives the
  minimum-norm Gauss-Newton step instead of a blow-up;
* accept the step when the actual relative reduction of ``|f|^2`` is at
  least 1e-4 of the reduction the linear model predicted; grow ``delta``
  when the model predicted well (ratio >= 0.75), shrink it when badly
  (ratio <= 0.25);
* stop when both reductions are below ``ftol``, when ``delta`` is below
  ``xtol |D x|``, when every column of ``J`` is within ``gtol`` of
  orthogonal to ``f`` (the scaled gradient test), or at ``max_evaluations``
  residual evaluations (never more).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: Machine epsilon: tolerances below it cannot be met and stop the fit instead.
EPS = float(np.finfo(float).eps)
#: Smallest positive normal float: the floor for a damping parameter that must not be 0.
TINY = float(np.finfo(float).tiny)
#: First trust radius, as a multiple of ``|D x0|`` (or absolute when ``x0`` is 0).
FACTOR = 100.0
#: A step is kept when the actual reduction is at least this part of the predicted one.
ACCEPT = 1e-4
#: Most damping-parameter trials per step (the radius need only be met within 10 %).
PAR_TRIALS = 10


@dataclass(frozen=True)
class LevMarResult:
    """Where :func:`levenberg_marquardt` stopped.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Parameters found.
    fun : ndarray, shape (m,)
        Residuals at ``x``.
    cost : float
        ``fun @ fun`` (not halved).
    evaluations : int
        Residual evaluations, the first one at ``x0`` included.
    jacobians : int
        Jacobian evaluations.
    status : str
        ``"ftol"``, ``"xtol"``, ``"ftol+xtol"``, ``"gtol"``, ``"max_evaluations"``
        or ``"precision"`` (a tolerance below machine precision cannot be met).
    message : str
        Why it stopped, in a sentence.
    """

    x: np.ndarray
    fun: np.ndarray
    cost: float
    evaluations: int
    jacobians: int
    status: str
    message: str

    @property
    def converged(self) -> bool:
        """Whether a convergence test (not the evaluation limit) stopped the fit."""
        return self.status != "max_evaluations"


def levenberg_marquardt(
    fun: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    jac: Callable[[np.ndarray], np.ndarray],
    *,
    max_evaluations: int = 200,
    ftol: float = 1e-14,
    xtol: float = 1e-14,
    gtol: float = 1e-14,
) -> LevMarResult:
    """Minimise ``|fun(x)|^2`` from ``x0`` (trust-region Levenberg-Marquardt, Jacobian scaling).

    Parameters
    ----------
    fun : callable
        ``fun(x)`` -> residuals, shape (m,) (any units: the sum of squares is minimised).
    x0 : array_like, shape (n,)
        Start.
    jac : callable
        ``jac(x)`` -> Jacobian of ``fun``, shape (m, n).
    max_evaluations : int
        Most calls of ``fun`` (the one at ``x0`` included); at least 1.
    ftol, xtol, gtol : float
        Relative reduction of ``|f|^2``, relative step (scaled by ``D``) and
        cosine between ``f`` and any column of ``J`` below which the fit has
        converged.

    Returns
    -------
    LevMarResult

    Raises
    ------
    ValueError
        ``x0`` or the residuals there are not finite, shapes disagree, or
        ``max_evaluations`` < 1.
    """
    if max_evaluations < 1:
        raise ValueError(f"max_evaluations must be at least 1, got {max_evaluations}")
    x = np.array(x0, dtype=float).ravel()
    if not np.all(np.isfinite(x)):
        raise ValueError("the start x0 is not finite")
    f = np.asarray(fun(x), dtype=float).ravel()
    evaluations, jacobians = 1, 0
    if not np.all(np.isfinite(f)):
        raise ValueError("the residuals at the start x0 are not finite")
    fnorm = float(np.linalg.norm(f))

    d: np.ndarray | None = None  # column scales, set from the first Jacobian
    delta = 0.0  # trust radius on |D p|
    par = 0.0  # damping parameter, carried from step to step as the next first guess
    accepted = 0
    while True:
        J = np.asarray(jac(x), dtype=float)
        jacobians += 1
        if J.shape != (f.size, x.size):
            raise ValueError(f"jac(x) has shape {J.shape}, expected {(f.size, x.size)}")
        colnorm = np.sqrt(np.einsum("ij,ij->j", J, J))
        if d is None:
            d = np.where(colnorm > 0, colnorm, 1.0)
            xnorm = float(np.linalg.norm(d * x))
            delta = FACTOR * xnorm if xnorm > 0 else FACTOR

        # Scaled gradient test: the largest |cos| between f and a column of J.
        gnorm = 0.0
        if fnorm > 0:
            live = colnorm > 0
            if np.any(live):
                gnorm = float(np.max(np.abs(J[:, live].T @ f) / (colnorm[live] * fnorm)))
        if gnorm <= gtol:
            return _result(x, f, evaluations, jacobians, "gtol")

        d = np.maximum(d, colnorm)
        # J D^-1 = U diag(s) V^T; a step is p = D^-1 V z' with z' from s and U^T f.
        u, s, vt = np.linalg.svd(J / d, full_matrices=False)
        uf = u.T @ f

        while True:  # trial steps until one is accepted or a test stops the fit
            par, p = _damped_step(s, uf, vt, d, f.size, delta, par)
            pnorm = float(np.linalg.norm(d * p))
            if accepted == 0:
                # The first radius is a guess: never let it exceed the first step.
                delta = min(delta, pnorm)
            if evaluations >= max_evaluations:
                return _result(x, f, evaluations, jacobians, "max_evaluations")
            x_trial = x + p
            f_trial = np.asarray(fun(x_trial), dtype=float).ravel()
            evaluations += 1
            fnorm_trial = float(np.linalg.norm(f_trial))

            # Relative reductions of |f|^2: actual, and predicted by the linear model.
            # A non-finite or tenfold larger |f| counts as a plain failure (-1).
            actred = 1.0 - (fnorm_trial / fnorm) ** 2 if 0.1 * fnorm_trial < fnorm else -1.0
            t1 = float(np.linalg.norm(J @ p)) / fnorm
            t2 = np.sqrt(par) * pnorm / fnorm
            prered = t1 * t1 + 2.0 * t2 * t2
            dirder = -(t1 * t1 + t2 * t2)
            ratio = actred / prered if prered != 0 else 0.0

            if ratio <= 0.25:
                # Poor model: shrink the radius, by the minimiser of the quadratic
                # through the directional derivative when the step went uphill.
                if actred >= 0:
                    shrink = 0.5
                else:
                    shrink = 0.5 * dirder / (dirder + 0.5 * actred)
                if 0.1 * fnorm_trial >= fnorm or not shrink >= 0.1:
                    shrink = 0.1
                delta = shrink * min(delta, pnorm / 0.1)
                par = par / shrink
            elif par == 0 or ratio >= 0.75:
                delta = pnorm / 0.5
                par = 0.5 * par

            if ratio >= ACCEPT:
                x, f, fnorm = x_trial, f_trial, fnorm_trial
                accepted += 1
            xnorm = float(np.linalg.norm(d * x))

            small_f = abs(actred) <= ftol and prered <= ftol and 0.5 * ratio <= 1
            small_x = delta <= xtol * xnorm
            if small_f or small_x:
                status = "ftol+xtol" if small_f and small_x else ("ftol" if small_f else "xtol")
                return _result(x, f, evaluations, jacobians, status)
            if (
                (abs(actred) <= EPS and prered <= EPS and 0.5 * ratio <= 1)
                or delta <= EPS * xnorm
                or gnorm <= EPS
            ):
                return _result(x, f, evaluations, jacobians, "precision")
            if ratio >= ACCEPT:
                break


def _damped_step(
    s: np.ndarray,
    uf: np.ndarray,
    vt: np.ndarray,
    d: np.ndarray,
    rows: int,
    delta: float,
    par: float,
) -> tuple[float, np.ndarray]:
    """The step of damping ``par`` whose scaled length is within 10 % of ``delta``.

    Parameters
    ----------
    s, uf, vt : ndarray
        Singular values of ``J D^-1``, shape (k,); ``U^T f``, shape (k,);
        ``V^T``, shape (k, n).
    d : ndarray, shape (n,)
        Column scales.
    rows : int
        Rows of ``J`` (for the rank threshold).
    delta : float
        Trust radius on ``|D p|``.
    par : float
        Previous damping parameter, the first guess.

    Returns
    -------
    par : float
        Damping chosen (0 for the Gauss-Newton step).
    p : ndarray, shape (n,)
        Step, minimiser of ``|J p + f|^2 + par |D p|^2``.
    """
    g = s * uf  # V^T of the scaled gradient D^-1 J^T f
    # Gauss-Newton: minimum-norm solution, singular values that are zero to
    # working precision left out (their directions do not change f).
    rank = s > (s[0] * EPS * max(rows, vt.shape[1]) if len(s) else 0.0)
    zgn = np.zeros_like(s)
    zgn[rank] = -uf[rank] / s[rank]

    def scaled(lam: float) -> np.ndarray:
        return -g / (s * s + lam)

    def length(z: np.ndarray, lam: float) -> tuple[float, float]:
        """|z| and d|z|/d lam."""
        zn = float(np.linalg.norm(z))
        if zn == 0:
            return 0.0, 0.0
        dz = float(np.sum(z * z / (s * s + lam))) / zn
        return zn, -dz

    def to_step(z: np.ndarray) -> np.ndarray:
        return (vt.T @ z) / d

    znorm = float(np.linalg.norm(zgn))
    fp = znorm - delta
    if fp <= 0.1 * delta:
        return 0.0, to_step(zgn)

    # Bounds on the damping that meets the radius: a lower one from a Newton
    # step at 0 when J has full rank, an upper one from the gradient's length.
    lower = 0.0
    if np.all(rank):
        _, slope = length(zgn, 0.0)
        if slope < 0:
            lower = -fp / slope * (znorm / delta)
    gnorm = float(np.linalg.norm(g))
    upper = gnorm / delta
    if upper == 0:
        upper = TINY / min(delta, 0.1)
    par = min(max(par, lower), upper)
    if par == 0:
        par = gnorm / znorm

    z = scaled(par)
    for trial in range(PAR_TRIALS):
        if par == 0:
            par = max(TINY, 0.001 * upper)
        z = scaled(par)
        znorm, slope = length(z, par)
        fp_old, fp = fp, znorm - delta
        if abs(fp) <= 0.1 * delta or (lower == 0 and fp <= fp_old < 0) or trial == PAR_TRIALS - 1:
            break
        # Newton on 1/|z| - 1/delta, which is nearly linear in par.
        correction = -fp / slope * (znorm / delta) if slope < 0 else 0.0
        if fp > 0:
            lower = max(lower, par)
        elif fp < 0:
            upper = min(upper, par)
        par = max(lower, par + correction)
    return par, to_step(z)


#: Why the fit stopped. The convergence sentences are scipy's, word for word, so
#: calibration.json's ``solver`` messages read as they did when scipy fitted.
MESSAGES = {
    "ftol": "`ftol` termination condition is satisfied.",
    "xtol": "`xtol` termination condition is satisfied.",
    "ftol+xtol": "Both `ftol` and `xtol` termination conditions are satisfied.",
    "gtol": "`gtol` termination condition is satisfied.",
    "max_evaluations": "stopped before converging: the limit of {n} residual evaluations reached.",
    "precision": "converged to machine precision: the tolerances cannot be met more closely.",
}


def _result(
    x: np.ndarray, f: np.ndarray, evaluations: int, jacobians: int, status: str
) -> LevMarResult:
    message = MESSAGES[status].format(n=evaluations)
    return LevMarResult(x, f, float(f @ f), evaluations, jacobians, status, message)
