"""What changed: the smallest set of joint zeros, base and reflector motion that explains a check.

Few poses cannot support a recalibration, but they can support a fit of a
few parameters. Each candidate cause is fitted to the errors by generalised
least squares (whitened by the errors' covariance ``V`` of
:mod:`calibrator.check.verdict`), a few Gauss-Newton steps on the calibrated
arm's kinematics; a cause *explains* the change when the errors left over
pass the check's own test (``p >= ALARM_P``). Causes are tried by size:
one joint's zero, the base (6: it or the tracker moved), the reflector on the
flange (3); then pairs of them. Among the explaining causes of the fewest
parts the one with the lowest ``chi2 + 2 k`` (Akaike: ``k`` parameters) is
named, with each parameter's value and standard error.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from calibrator.check.model import Calibrated
from calibrator.check.verdict import ALARM_P, p_value
from calibrator.model import measurement, parameters

#: Causes a check can name: their label and parameters.
CAUSES = tuple((f"joint {j} zero", (f"theta{j}",)) for j in range(1, 7)) + (
    ("base", parameters.BASE_NAMES),
    ("reflector", parameters.TOOL_NAMES),
)
#: Gauss-Newton steps of each fit (a crash of a few mrad is not quite linear).
STEPS = 3
#: A cause whose columns move no measured point by this much per unit (mm per mm or rad) is
#: invisible from these poses (joint 6 with the reflector on its axis).
INVISIBLE = 1e-6


@dataclass(frozen=True)
class Fit:
    """One candidate cause fitted to the errors.

    Attributes
    ----------
    causes : tuple of str
    names : tuple of str
        Its parameters.
    value, se : ndarray, shape (k,)
        Fitted change and standard error (mm, rad).
    chi2 : float
        Whitened errors left over.
    p_value : float
        Chance of ``chi2`` that large from noise alone (``3N - k`` degrees of freedom;
        see :func:`calibrator.check.verdict.p_value`).
    """

    causes: tuple
    names: tuple
    value: np.ndarray
    se: np.ndarray
    chi2: float
    p_value: float

    @property
    def explains(self) -> bool:
        return self.p_value >= ALARM_P

    @property
    def aic(self) -> float:
        return self.chi2 + 2 * len(self.names)

    def sentences(self) -> list[str]:
        """One line per cause: what moved, by how much, what to do."""
        out = []
        for cause in self.causes:
            idx = [self.names.index(n) for n in dict(CAUSES)[cause]]
            out.append(_sentence(cause, self.value[idx], self.se[idx], self.names))
        return out

    def to_json(self) -> dict:
        return {
            "causes": list(self.causes),
            "parameters": [
                {
                    "name": n,
                    "change": float(v),
                    "standard_error": float(s),
                    "unit": parameters.unit(n),
                }
                for n, v, s in zip(self.names, self.value, self.se, strict=True)
            ],  # fmt: skip
            "chi2": self.chi2,
            "p_value": self.p_value,
            "explains": self.explains,
            "text": self.sentences(),
        }


def explain(
    model: Calibrated, q: ArrayLike, measured_mm: ArrayLike, cov: np.ndarray, max_causes: int = 2
) -> tuple[Fit | None, list[Fit]]:
    """The smallest explaining cause, and every fit tried (in the order tried).

    Parameters
    ----------
    model : Calibrated
    q : array_like, shape (N, 6)
        Read-back joints of the check poses, rad.
    measured_mm : array_like, shape (N, 3)
        Measured points, tracker frame, mm.
    cov : ndarray, shape (3N, 3N)
        The errors' covariance, mm^2.
    max_causes : int
        Largest number of causes combined.

    Returns
    -------
    best : Fit or None
        None: no combination of up to ``max_causes`` causes explains the change.
    tried : list of Fit
    """
    q = np.asarray(q, float)
    points = np.asarray(measured_mm, float)
    whiten = np.linalg.inv(np.linalg.cholesky(cov))
    visible = [c for c in CAUSES if _visible(model, q, c[1])]
    tried: list[Fit] = []
    for size in range(1, max_causes + 1):
        level = []
        for combo in itertools.combinations(visible, size):
            names = tuple(n for _, group in combo for n in group)
            if 3 * len(q) - len(names) < 1:
                continue
            level.append(_fit(model, q, points, whiten, tuple(c for c, _ in combo), names))
        tried += level
        good = [f for f in level if f.explains]
        if good:
            return min(good, key=lambda f: f.aic), tried
    return None, tried


def _visible(model: Calibrated, q: np.ndarray, names: tuple) -> bool:
    jac = model.jacobian(q, names).reshape(-1, len(names))
    return bool(np.all(np.linalg.norm(jac, axis=0) > INVISIBLE))


def _fit(model, q, points, whiten, causes, names) -> Fit:
    """Gauss-Newton on the calibrated arm with ``names`` free, whitened by ``whiten``."""
    base = model.space
    space = parameters.ParameterSpace(base.nominal_mdh, base.base0, base.tool0, names)
    q_eff = model.angles(q)
    obs = measurement.Observations(q_eff, points)
    x = np.zeros(len(names))
    for _ in range(STEPS):
        r = whiten @ measurement.residuals(space, x, obs)
        a = whiten @ measurement.jacobian(space, x, obs)
        step, *_ = np.linalg.lstsq(a, -r, rcond=None)
        x = x + step
    r = whiten @ measurement.residuals(space, x, obs)
    a = whiten @ measurement.jacobian(space, x, obs)
    cov = np.linalg.pinv(a.T @ a)
    chi2 = float(r @ r)
    dof = len(r) - len(names)
    p = p_value(chi2, dof, model.noise_dof)
    return Fit(causes, names, x, np.sqrt(np.maximum(np.diag(cov), 0.0)), chi2, p)


_ADVICE = {
    "base": "re-register the base (or the tracker moved) and re-check, or recalibrate",
    "reflector": "re-seat the reflector (or re-identify the tool), or recalibrate",
}


def _sentence(cause: str, value: np.ndarray, se: np.ndarray, names: tuple) -> str:
    if cause.startswith("joint"):
        j = cause.split()[1]
        also = {
            "1": " (or the base turned about joint 1's axis)",
            "6": " (or the reflector turned about the flange axis)",
        }.get(j, "")
        return (
            f"joint {j} zero moved {value[0] * 1e3:+.3f} ± {se[0] * 1e3:.3f} mrad{also}: "
            f"re-master J{j} or recalibrate"
        )
    if cause == "base":
        shift, turn = _size(value[:3], se[:3]), _size(value[3:] * 1e3, se[3:] * 1e3)
        return (
            f"the base moved {shift[0]:.3f} ± {shift[1]:.3f} mm and turned "
            f"{turn[0]:.3f} ± {turn[1]:.3f} mrad: {_ADVICE['base']}"
        )
    shift = _size(value, se)
    return (
        f"the reflector moved {shift[0]:.3f} ± {shift[1]:.3f} mm on the flange: "
        f"{_ADVICE['reflector']}"
    )


def _size(v: np.ndarray, se: np.ndarray) -> tuple[float, float]:
    """Length of a vector and its standard error (first order, independent components)."""
    norm = float(np.linalg.norm(v))
    if norm == 0:
        return 0.0, float(np.linalg.norm(se))
    return norm, float(np.sqrt(np.sum((v / norm) ** 2 * se**2)))
