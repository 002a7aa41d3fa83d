"""What two calibrations of one arm may be compared on, and whether the arm moved between them.

A calibration identifies three things: the arm (its joint geometry, zeros
and joint terms), the tool on its flange and its base in the tracker frame.
Only the arm belongs to the robot:

- the joint parameters are always compared, as identified values (nominal
  plus delta), so two sessions with other nominal tables still compare;
- the tool only when both sessions declare the same tool (the footer's
  ``tool_id``): the reflector and its nest are re-seated, swapped and guessed
  anew in every session, and its deltas are offsets from each run's own
  first guess. Compared, it is the identified tool frame itself;
- the base only when both sessions record the tracker's pose in the same
  world frame (the footer's ``tracker_pose``: ``world`` and
  ``tracker2world``, e.g. from fixed reference nests): the tracker is set up
  anew for every session, so ``base2tracker`` says where the tracker stood,
  not where the arm is. Compared, it is ``base2world``, as the move of the
  later base in the earlier one's frame.

The difference ``d`` of the compared values has the covariance ``Va + Vb``
of the two calibrations' (each with its correlations; the sessions are
independent). The pair moved when ``d^T (Va + Vb)^+ d`` exceeds its
chi-square quantile at :data:`ALARM_P` (one false alarm in 1000 pairs of an
unchanged arm), and then the fewest parameters whose changes (fitted by
generalised least squares) leave a difference that passes the same test are
named, each with its change and standard error.
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from scipy import stats

from calibrator.model import rotations

if TYPE_CHECKING:
    from calibrator.calibration import Calibration

#: Chance that two calibrations of an unchanged arm raise an alarm.
ALARM_P = 1e-3
#: Most parameters named for one pair (beyond: the first ones found greedily).
MAX_NAMED = 6

BASE_NAMES = ("base_tx", "base_ty", "base_tz", "base_rx", "base_ry", "base_rz")
TOOL_PREFIX = "tool_"


def category(name: str) -> str:
    """``base``, ``tool`` or ``arm`` (joint geometry, zeros, joint terms)."""
    if name in BASE_NAMES:
        return "base"
    if name.startswith(TOOL_PREFIX):
        return "tool"
    return "arm"


@dataclass(frozen=True)
class State:
    """One calibration as the history compares it.

    Attributes
    ----------
    names : tuple of str
        Free parameters (calibration.json's names).
    values : ndarray, shape (P,)
        Identified values: MDH entries (mm, rad), joint terms, the tool point
        (flange frame, mm) and ``Rx Ry Rz`` angles of the tool rotation (rad);
        base entries are their deltas (the base is compared by ``base2world``).
    cov : ndarray, shape (P, P)
        Covariance of the free parameters (mm, rad), from their standard
        errors and correlations.
    tool : str or None
        The tool the session declares (``tool_id``); None: not declared.
    world : str or None
        The world frame the tracker's pose was recorded in; None: not recorded.
    base2world : ndarray, shape (4, 4) or None
        The identified base in that world frame (mm).
    """

    names: tuple[str, ...]
    values: np.ndarray
    cov: np.ndarray
    tool: str | None = None
    world: str | None = None
    base2world: np.ndarray | None = None


@dataclass(frozen=True)
class Change:
    """One parameter named as moved: its change and standard error (mm or rad)."""

    name: str
    change: float
    standard_error: float


@dataclass
class Comparison:
    """How two calibrations compare.

    Attributes
    ----------
    compared : tuple of str
        Parameters compared.
    not_compared : list of str
        Sentences: what was not compared and why.
    statistic, threshold : float
        ``d^T V^+ d`` and its chi-square quantile at :data:`ALARM_P`.
    dof : int
    p_value : float
    changes : list of Change
        The parameters named (empty when the pair passes).
    """

    compared: tuple[str, ...] = ()
    not_compared: list[str] = field(default_factory=list)
    statistic: float = 0.0
    threshold: float = 0.0
    dof: int = 0
    p_value: float = 1.0
    changes: list[Change] = field(default_factory=list)

    @property
    def moved(self) -> bool:
        return self.p_value < ALARM_P


def state_of(row: dict) -> State:
    """A calibration row of the history as a :class:`State`.

    A row recorded with its ``statistics["arm"]`` (values, covariance, the
    base frame) and ``statistics["setup"]`` (tool, tracker pose) gives them
    all; an older row gives its deltas and standard errors (no correlations)
    and compares the joint parameters only.
    """
    arm = (row.get("statistics") or {}).get("arm")
    setup = (row.get("statistics") or {}).get("setup") or {}
    if isinstance(arm, dict) and arm.get("names"):
        names = tuple(arm["names"])
        values = np.asarray(arm["values"], float)
        cov = np.asarray(arm["covariance"], float)
        base = arm.get("base2tracker")
    else:
        se = row.get("uncertainties") or {}
        names = tuple(n for n in row["parameters"] if n in se and category(n) == "arm")
        values = np.array([row["parameters"][n] for n in names], float)
        cov = np.diag([float(se[n]) ** 2 for n in names])
        base, setup = None, {}
    pose = setup.get("tracker_pose") if isinstance(setup, dict) else None
    world = base2world = None
    if isinstance(pose, dict) and base is not None:
        world = str(pose["world"])
        base2world = np.asarray(pose["tracker2world"], float) @ np.asarray(base, float)
    tool = setup.get("tool_id") if isinstance(setup, dict) else None
    return State(names, values, cov, tool, world, base2world)


def compare(before: State, after: State) -> Comparison:
    """Compare two calibrations (:class:`State`) of one arm: what moved beyond their noise."""
    result = Comparison()
    kinds = {"arm"}
    if before.tool is not None and before.tool == after.tool:
        kinds.add("tool")
    elif any(category(n) == "tool" for n in before.names + after.names):
        result.not_compared.append(
            "tool not compared: "
            + (
                "the sessions declare no tool (tool_id)"
                if before.tool is None or after.tool is None
                else f"another tool ({before.tool} then {after.tool})"
            )
        )
    common_base = all(n in before.names and n in after.names for n in BASE_NAMES)
    if (
        before.world is not None
        and before.world == after.world
        and common_base
        and before.base2world is not None
        and after.base2world is not None
    ):
        kinds.add("base")
    else:
        result.not_compared.append(
            "base not compared: the tracker's pose is not recorded in one world frame "
            "in both sessions (tracker_pose)"
        )
    names = tuple(n for n in before.names if n in after.names and category(n) in kinds)
    if not names:
        return result
    ia = [before.names.index(n) for n in names]
    ib = [after.names.index(n) for n in names]
    d = np.asarray(after.values, float)[ib] - np.asarray(before.values, float)[ia]
    if "base" in kinds:
        move = np.linalg.solve(before.base2world, after.base2world)  # type: ignore[arg-type]

        rel = np.concatenate([move[:3, 3], rotations.angles_xyz(move[:3, :3])])
        for k, name in enumerate(BASE_NAMES):
            d[names.index(name)] = rel[k]
    cov = before.cov[np.ix_(ia, ia)] + after.cov[np.ix_(ib, ib)]
    result.compared = names
    result.statistic, result.dof = _chi2(d, cov)
    if result.dof == 0:
        return result
    result.threshold = float(stats.chi2.isf(ALARM_P, result.dof))
    result.p_value = float(stats.chi2.sf(result.statistic, result.dof))
    if result.moved:
        result.changes = _explain(names, d, cov, result.dof)
    return result


def _pinv(cov: np.ndarray) -> tuple[np.ndarray, int]:
    """Pseudo-inverse of a covariance and its rank (directions with no variance dropped)."""
    sym = 0.5 * (cov + cov.T)
    w, u = np.linalg.eigh(sym)
    keep = w > max(w.max(initial=0.0), 0.0) * 1e-12
    return (u[:, keep] / w[keep]) @ u[:, keep].T, int(keep.sum())


def _chi2(d: np.ndarray, cov: np.ndarray) -> tuple[float, int]:
    inv, rank = _pinv(cov)
    return float(d @ inv @ d), rank


def _explain(names: tuple[str, ...], d: np.ndarray, cov: np.ndarray, dof: int) -> list[Change]:
    """The fewest parameters whose changes leave a difference that passes the test.

    Singles, then pairs, then greedily more (up to :data:`MAX_NAMED`); among
    equally small sets the one with the smallest chi-square left is named.
    """
    inv, _ = _pinv(cov)
    n = len(names)

    def fit(subset: tuple[int, ...]) -> tuple[float, np.ndarray, np.ndarray] | None:
        e = np.zeros((n, len(subset)))
        e[list(subset), range(len(subset))] = 1.0
        normal = e.T @ inv @ e
        if np.linalg.cond(normal) > 1e12:
            return None
        c_cov = np.linalg.inv(normal)
        c = c_cov @ (e.T @ inv @ d)
        r = d - e @ c
        return float(r @ inv @ r), c, np.sqrt(np.diag(c_cov))

    def passes(chi2: float, k: int) -> bool:
        return dof - k <= 0 or stats.chi2.sf(chi2, dof - k) >= ALARM_P

    best = None
    for size in (1, 2):
        fits = [
            (f[0], s, f)
            for s in itertools.combinations(range(n), size)
            if (f := fit(s)) is not None
        ]
        good = [x for x in fits if passes(x[0], size)]
        if good:
            best = min(good, key=lambda x: x[0])
            break
    if best is None:
        chosen: tuple[int, ...] = ()
        for _ in range(MAX_NAMED):
            options = [
                (f[0], chosen + (j,), f)
                for j in range(n)
                if j not in chosen and (f := fit(chosen + (j,))) is not None
            ]
            if not options:
                break
            best = min(options, key=lambda x: x[0])
            chosen = best[1]
            if passes(best[0], len(chosen)):
                break
    if best is None:
        return []
    _, subset, (_, c, se) = best
    return [Change(names[j], float(c[i]), float(se[i])) for i, j in enumerate(subset)]


#: Names of calibration.json's parameters that are MDH entries: column, joint.
_MDH = re.compile(r"(a|alpha|theta|d|beta)([1-6])")


def arm_block(cal: Calibration) -> dict:
    """What the history keeps of a calibration to compare it (``statistics["arm"]``).

    Parameters
    ----------
    cal : calibrator.calibration.Calibration

    Returns
    -------
    dict
        ``names`` (free parameters), ``values`` (identified values, see
        :class:`State`), ``covariance`` (P x P, mm and rad) and
        ``base2tracker`` (4 x 4, mm); ``{}`` when the calibration records no
        standard errors.
    """
    from calibrator.model import kinematics

    unc = cal.fit.uncertainty
    se = unc.get("standard_errors") or {}
    names = tuple(n for n in cal.free if n in se)
    if not names:
        return {}
    corr: dict = dict(unc.get("correlation") or {})
    where = {n: i for i, n in enumerate(corr.get("names") or [])}
    matrix = np.asarray(corr.get("matrix") or np.eye(len(where)), float)
    cov = np.diag([float(se[n]) ** 2 for n in names])
    for a, na in enumerate(names):
        for b, nb in enumerate(names):
            if a != b and na in where and nb in where:
                cov[a, b] = matrix[where[na], where[nb]] * se[na] * se[nb]
    tool = np.asarray(cal.flange2tool, float)
    tool_angles = rotations.angles_xyz(tool[:3, :3])
    mdh = np.asarray(cal.mdh, float)
    values = []
    for n in names:
        match = _MDH.fullmatch(n)
        if match:
            values.append(mdh[int(match[2]) - 1, kinematics.COLUMNS.index(match[1])])
        elif n in ("tool_x", "tool_y", "tool_z"):
            values.append(tool["xyz".index(n[-1]), 3])
        elif n in ("tool_rx", "tool_ry", "tool_rz"):
            values.append(tool_angles["xyz".index(n[-1])])
        else:  # base entries and joint terms: their deltas
            values.append(float(cal.deltas[n]))
    return {
        "names": list(names),
        "values": [float(v) for v in values],
        "covariance": cov.tolist(),
        "base2tracker": np.asarray(cal.base2tracker, float).tolist(),
    }
