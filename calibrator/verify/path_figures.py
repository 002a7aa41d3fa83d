"""ISO 9283 clause 7: path accuracy, repeatability, corner deviations, path velocity.

The pose test (:mod:`calibrator.verify.iso9283`) looks at where the arm stops; this
module looks at how it moves between, from time-stamped streams of attained
positions (a laser tracker following the reflector while the arm runs a
commanded path ``n`` times). The figures, with the standard's symbols:

- **7.2 path accuracy** ``AT_P``: at each of ``m`` calculated points of the
  commanded path, the ``n`` attained paths cross the plane normal to the
  commanded path there at ``x_ij`` (``i`` the point, ``j`` the cycle); their
  barycentre ``xbar_i`` lies ``|xbar_i - x_ci|`` from the commanded point,
  and ``AT_P = max_i |xbar_i - x_ci|``. With orientations,
  ``AT_a = max_i |abar_i - a_ci|`` (and b, c).
- **7.3 path repeatability** ``RT_P = max_i (lbar_i + 3 S_li)`` with
  ``l_ij = |x_ij - xbar_i|`` and ``S_li`` their sample standard deviation
  (``n - 1``); ``RT_a = max_i 3 S_ai`` (and b, c).
- **7.5 corner deviations**, per corner and cycle: the corner round-off
  error ``CR``, the smallest distance from the corner point to the attained
  path, and the corner overshoot ``CO``, the largest deviation of the
  attained path beyond the second segment's line, on the outer side of the
  corner, once the arm has turned into that segment.
- **7.6 path velocity**: from ``v_ij`` the path speeds of cycle ``j`` on its
  constant-speed stretch, ``vbar_j`` their mean, ``vbar`` the mean of the
  ``vbar_j`` and ``v_c`` the commanded speed: accuracy
  ``AV = (vbar - v_c) / v_c * 100 %``, repeatability
  ``RV = 3 S_v / v_c * 100 %`` (``S_v`` the sample standard deviation of the
  ``vbar_j``; the standard writes it ``+-``) and fluctuation
  ``FV = max_j (max_i v_ij - min_i v_ij)``, mm/s.

A robot stream and a tracker stream run on different clocks; a constant
latency between them is found by :func:`estimate_latency` (least squares of
the position difference over a trial latency, the continuous form of a
cross-correlation), against the robot's own stream
(:func:`stream_reference`) or against the commanded path's timing
(:func:`commanded_reference`) when the controller streams nothing.

Everything is in one frame (the robot base frame once the tracker readings
went through ``tracker2base``), in mm, s and rad, and vectorised over
samples and calculated points; the cycles, whose sample counts differ, are
looped over. The computations are pure numpy (scipy's KD-tree for nearest
points, its bounded scalar minimiser for the latency).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt
from scipy.optimize import minimize_scalar
from scipy.spatial import cKDTree

from calibrator.errors import CalibrationError

#: Points per mm with which a commanded path is sampled to find the nearest
#: path parameter of a measured point (refined by projection afterwards).
_DENSE_PER_MM = 2.0
#: Slack when looking for the samples on either side of a normal plane by their
#: path parameters, mm: covers the projection's second-order error on a circle.
_BRACKET_SLACK_MM = 0.05
#: Samples of the measured stream used for the latency's grid search (all of them refine it).
_GRID_SAMPLES = 500


class PathError(CalibrationError):
    """A commanded path or a measured stream that cannot give the clause 7 figures."""


# ---------------------------------------------------------------- commanded paths


@dataclass(frozen=True)
class Polyline:
    """A commanded path of straight segments: a line, or a rectangle with corners.

    Attributes
    ----------
    vertices_mm : ndarray, shape (V, 3)
        Vertices in travel order, base frame, mm; a closed path repeats the
        first vertex at the end.
    """

    vertices_mm: np.ndarray
    _starts: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices_mm, dtype=float)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 2 or not np.all(np.isfinite(v)):
            raise PathError(f"a polyline needs finite vertices of shape (V >= 2, 3), got {v.shape}")
        lengths = np.linalg.norm(np.diff(v, axis=0), axis=1)
        if np.any(lengths <= 0.0):
            raise PathError("a polyline's consecutive vertices must differ")
        object.__setattr__(self, "vertices_mm", v)
        object.__setattr__(self, "_starts", np.concatenate([[0.0], np.cumsum(lengths)]))

    @property
    def length_mm(self) -> float:
        """Arc length of the whole path, mm."""
        return float(self._starts[-1])

    @property
    def corner_s_mm(self) -> np.ndarray:
        """Arc length at the inner vertices (the corners), shape (V - 2,), mm."""
        return self._starts[1:-1].copy()

    def _segment(self, s_mm: np.ndarray) -> np.ndarray:
        return np.clip(
            np.searchsorted(self._starts, s_mm, side="right") - 1, 0, len(self._starts) - 2
        )

    def point(self, s_mm: npt.ArrayLike) -> np.ndarray:
        """Commanded points at arc lengths ``s_mm`` (shape (K,)), shape (K, 3), mm."""
        s = np.asarray(s_mm, dtype=float)
        k = self._segment(s)
        return self.vertices_mm[k] + (s - self._starts[k])[..., None] * self.tangent(s)

    def tangent(self, s_mm: npt.ArrayLike) -> np.ndarray:
        """Unit travel directions at ``s_mm`` (a corner belongs to the segment after it), (K, 3)."""
        s = np.asarray(s_mm, dtype=float)
        d = np.diff(self.vertices_mm, axis=0)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d[self._segment(s)]


def line(start_mm: npt.ArrayLike, end_mm: npt.ArrayLike) -> Polyline:
    """A straight commanded path from ``start_mm`` to ``end_mm`` (each shape (3,), mm)."""
    return Polyline(np.array([start_mm, end_mm], dtype=float))


def rectangle(corners_mm: npt.ArrayLike) -> Polyline:
    """A closed commanded rectangle through four corners (shape (4, 3), mm), back to the first.

    Its corners for :func:`corner_figures` are the second, third and fourth
    (the first is where the path starts and ends, not a corner it runs through).
    """
    c = np.asarray(corners_mm, dtype=float)
    if c.shape != (4, 3):
        raise PathError(f"a rectangle needs corners of shape (4, 3), got {c.shape}")
    return Polyline(np.vstack([c, c[:1]]))


@dataclass(frozen=True)
class Circle:
    """A commanded circle (or arc), travelled counter-clockwise about ``normal``.

    Attributes
    ----------
    centre_mm : ndarray, shape (3,)
        Centre, base frame, mm.
    normal : ndarray, shape (3,)
        Unit normal of its plane; travel is right-handed about it.
    radius_mm : float
        Radius, mm.
    start_mm : ndarray, shape (3,)
        Unit vector from the centre to the start point (in the plane).
    turns : float
        Angle travelled in turns (1: one full circle).
    """

    centre_mm: np.ndarray
    normal: np.ndarray
    radius_mm: float
    start_mm: np.ndarray
    turns: float = 1.0

    @property
    def length_mm(self) -> float:
        return float(2.0 * np.pi * self.radius_mm * self.turns)

    @property
    def corner_s_mm(self) -> np.ndarray:
        return np.zeros(0)

    def _angle(self, s_mm: npt.ArrayLike) -> np.ndarray:
        return np.asarray(s_mm, dtype=float) / self.radius_mm

    def point(self, s_mm: npt.ArrayLike) -> np.ndarray:
        """Commanded points at arc lengths ``s_mm`` (shape (K,)), shape (K, 3), mm."""
        th = self._angle(s_mm)[..., None]
        u, w = self.start_mm, np.cross(self.normal, self.start_mm)
        return self.centre_mm + self.radius_mm * (np.cos(th) * u + np.sin(th) * w)

    def tangent(self, s_mm: npt.ArrayLike) -> np.ndarray:
        """Unit travel directions at ``s_mm``, shape (K, 3)."""
        th = self._angle(s_mm)[..., None]
        u, w = self.start_mm, np.cross(self.normal, self.start_mm)
        return -np.sin(th) * u + np.cos(th) * w


def circle(
    centre_mm: npt.ArrayLike,
    normal: npt.ArrayLike,
    radius_mm: float,
    start_direction: npt.ArrayLike,
    turns: float = 1.0,
) -> Circle:
    """A commanded circle; ``start_direction`` is projected into its plane and normalised.

    Parameters
    ----------
    centre_mm : array_like, shape (3,)
        Centre, base frame, mm.
    normal : array_like, shape (3,)
        Normal of the circle's plane (any length); travel is counter-clockwise about it.
    radius_mm : float
        Radius, mm (> 0).
    start_direction : array_like, shape (3,)
        From the centre towards the start point (not parallel to ``normal``).
    turns : float
        Angle travelled, in turns.
    """
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n)
    d = np.asarray(start_direction, dtype=float)
    d = d - (d @ n) * n
    if not (radius_mm > 0 and np.linalg.norm(d) > 1e-9 and turns > 0):
        raise PathError("a circle needs a radius > 0, turns > 0 and a start direction in its plane")
    return Circle(
        np.asarray(centre_mm, dtype=float), n, float(radius_mm), d / np.linalg.norm(d), turns
    )


CommandedPath = Polyline | Circle


# ---------------------------------------------------------------- streams


@dataclass(frozen=True)
class Stream:
    """One cycle's time-stamped attained positions (and orientations).

    Attributes
    ----------
    t_s : ndarray, shape (K,)
        Time stamps, s, strictly increasing.
    p_mm : ndarray, shape (K, 3)
        Attained positions, base frame, mm.
    abc_rad : ndarray, shape (K, 3), or None
        Attained orientation angles ``(a, b, c)`` about x, y, z, rad
        (:func:`calibrator.model.rotations.angles_xyz`), when the probe gives them.
    """

    t_s: np.ndarray
    p_mm: np.ndarray
    abc_rad: np.ndarray | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.t_s, dtype=float)
        p = np.asarray(self.p_mm, dtype=float)
        a = None if self.abc_rad is None else np.asarray(self.abc_rad, dtype=float)
        if t.ndim != 1 or p.shape != (len(t), 3) or (a is not None and a.shape != p.shape):
            raise PathError(
                f"a stream needs t_s (K,), p_mm (K, 3) and abc_rad (K, 3) or None, got "
                f"{t.shape}, {p.shape}, {None if a is None else a.shape}"
            )
        if len(t) < 2 or np.any(np.diff(t) <= 0) or not np.all(np.isfinite(p)):
            raise PathError("a stream needs >= 2 finite samples with increasing time stamps")
        object.__setattr__(self, "t_s", t)
        object.__setattr__(self, "p_mm", p)
        object.__setattr__(self, "abc_rad", a)


def _dense(path: CommandedPath) -> tuple[np.ndarray, np.ndarray]:
    """The commanded path sampled densely: arc lengths (D,) and points (D, 3)."""
    count = max(int(np.ceil(path.length_mm * _DENSE_PER_MM)), 2) + 1
    s = np.linspace(0.0, path.length_mm, count)
    return s, path.point(s)


def path_parameter(path: CommandedPath, p_mm: npt.ArrayLike) -> np.ndarray:
    """Arc length of the commanded point nearest to each measured point.

    Parameters
    ----------
    path : Polyline or Circle
    p_mm : array_like, shape (K, 3)
        Measured points, base frame, mm.

    Returns
    -------
    ndarray, shape (K,)
        Arc length along the commanded path, mm, in ``[0, length_mm]``:
        the nearest of a dense sampling, refined by projecting onto the
        local tangent (exact on straight segments, to second order on a circle).
    """
    s_dense, x_dense = _dense(path)
    p = np.asarray(p_mm, dtype=float)
    _, k = cKDTree(x_dense).query(p)
    s0 = s_dense[k]
    step = s_dense[1] - s_dense[0]
    ds = np.einsum("kj,kj->k", p - path.point(s0), path.tangent(s0))
    return np.clip(s0 + np.clip(ds, -step, step), 0.0, path.length_mm)


# ---------------------------------------------------------------- 7.2 and 7.3


def calculated_points(path: CommandedPath, m: int, margin_mm: float = 0.0) -> np.ndarray:
    """Arc lengths of ``m`` evenly spaced calculated points, shape (m,), mm.

    ``margin_mm`` keeps them that far from the path's ends and corners, where
    the normal plane is undefined (at a corner) or the arm accelerates.
    """
    if m < 1:
        raise PathError(f"need at least one calculated point, got m={m}")
    bounds = np.concatenate([[0.0], path.corner_s_mm, [path.length_mm]])
    # Lay the points over the usable stretches in proportion to their lengths.
    lo, hi = bounds[:-1] + margin_mm, bounds[1:] - margin_mm
    usable = np.clip(hi - lo, 0.0, None)
    if usable.sum() <= 0:
        raise PathError(f"no stretch of the path is longer than twice the margin {margin_mm} mm")
    u = (np.arange(m) + 0.5) / m * usable.sum()
    edges = np.concatenate([[0.0], np.cumsum(usable)])
    k = np.clip(np.searchsorted(edges, u, side="right") - 1, 0, len(usable) - 1)
    return lo[k] + (u - edges[k])


def normal_plane_crossings(
    path: CommandedPath, s_mm: npt.ArrayLike, stream: Stream
) -> tuple[np.ndarray, np.ndarray | None]:
    """Where one attained path crosses the normal planes at the calculated points.

    Parameters
    ----------
    path : Polyline or Circle
    s_mm : array_like, shape (m,)
        Arc lengths of the calculated points, mm.
    stream : Stream
        One cycle's attained path.

    Returns
    -------
    x : ndarray, shape (m, 3)
        Crossing points ``x_ij``, base frame, mm, linear between the two
        samples on either side of the plane (the crossing nearest to the
        commanded point when the path crosses the plane more than once);
        NaN where the stream never crosses that plane.
    abc : ndarray, shape (m, 3), or None
        Orientation angles at the crossings, rad, interpolated alike.
    """
    s = np.asarray(s_mm, dtype=float)
    c, t = path.point(s), path.tangent(s)
    p = stream.p_mm
    # Candidate sample pairs: those whose nearest path parameters bracket a calculated
    # point (with a little slack for the curvature), so the exact plane test below runs
    # on a few pairs per point rather than on every sample (m x K vectors).
    sp = path_parameter(path, p)
    lo = np.minimum(sp[:-1], sp[1:]) - _BRACKET_SLACK_MM
    hi = np.maximum(sp[:-1], sp[1:]) + _BRACKET_SLACK_MM
    i, k = np.nonzero((lo[None, :] <= s[:, None]) & (s[:, None] <= hi[None, :]))
    # Signed distances of both samples from plane i.
    d0 = np.einsum("qj,qj->q", p[k] - c[i], t[i])
    d1 = np.einsum("qj,qj->q", p[k + 1] - c[i], t[i])
    cross = ((d0 <= 0.0) & (d1 > 0.0)) | ((d0 >= 0.0) & (d1 < 0.0))
    i, k, d0, d1 = i[cross], k[cross], d0[cross], d1[cross]
    w = d0 / (d0 - d1)  # fraction of the way to the next sample
    x = p[k] + w[:, None] * (p[k + 1] - p[k])
    dist = np.linalg.norm(x - c[i], axis=1)
    # Per plane the crossing nearest its commanded point: sort by (plane, distance).
    order = np.lexsort((dist, i))
    first = order[np.r_[True, i[order][1:] != i[order][:-1]]] if len(order) else order
    out = np.full((len(s), 3), np.nan)
    out[i[first]] = x[first]
    abc = None
    if stream.abc_rad is not None:
        a0, a1 = stream.abc_rad[k[first]], stream.abc_rad[k[first] + 1]
        step = np.angle(np.exp(1j * (a1 - a0)))  # across +-pi the short way
        abc = np.full((len(s), 3), np.nan)
        abc[i[first]] = a0 + w[first][:, None] * step
    return out, abc


def path_figures(
    path: CommandedPath,
    streams: Sequence[Stream],
    m: int = 100,
    margin_mm: float = 0.0,
    commanded_abc_rad: npt.ArrayLike | None = None,
) -> dict:
    """Path accuracy (7.2) and path repeatability (7.3) of ``n`` cycles.

    Parameters
    ----------
    path : Polyline or Circle
        The commanded path, base frame, mm.
    streams : sequence of Stream
        One attained path per cycle, same frame (``n >= 1``; RT needs ``n >= 2``).
    m : int
        Number of calculated points along the path.
    margin_mm : float
        Keep the calculated points this far from the ends and corners, mm.
    commanded_abc_rad : array_like, shape (3,) or (m, 3), optional
        Commanded orientation angles ``(a, b, c)``, rad; with orientation
        streams, gives ``AT_a..c`` and ``RT_a..c``.

    Returns
    -------
    dict
        ``AT_P_mm`` (float), ``RT_P_mm`` (float, NaN for one cycle),
        ``s_mm`` (m,) the calculated points, ``AT_i_mm`` (m,) and
        ``RT_i_mm`` (m,) per calculated point, ``barycentre_mm`` (m, 3);
        with orientations also ``ATa_deg`` .. ``ATc_deg`` and
        ``RTa_deg`` .. ``RTc_deg`` (floats, degrees, as the pose figures).

    Raises
    ------
    PathError
        No streams, or a cycle that never crosses the normal plane of some
        calculated point (it did not run the whole path).
    """
    if len(streams) < 1:
        raise PathError("path figures need at least one cycle")
    s = calculated_points(path, m, margin_mm)
    crossings = [normal_plane_crossings(path, s, st) for st in streams]
    x = np.stack([cx for cx, _ in crossings], axis=1)  # (m, n, 3)
    missing = np.isnan(x[..., 0])
    if missing.any():
        i, j = np.argwhere(missing)[0]
        raise PathError(
            f"cycle {j + 1} does not reach the calculated point at {s[i]:.1f} mm "
            f"of the {path.length_mm:.1f} mm path"
        )
    xbar = x.mean(axis=1)
    at_i = np.linalg.norm(xbar - path.point(s), axis=1)
    n = x.shape[1]
    if n >= 2:
        l_ij = np.linalg.norm(x - xbar[:, None, :], axis=2)
        rt_i = l_ij.mean(axis=1) + 3.0 * l_ij.std(axis=1, ddof=1)
    else:
        rt_i = np.full(len(s), np.nan)
    out: dict = {
        "AT_P_mm": float(at_i.max()),
        "RT_P_mm": float(rt_i.max()),
        "s_mm": s,
        "AT_i_mm": at_i,
        "RT_i_mm": rt_i,
        "barycentre_mm": xbar,
    }
    abcs = [a for _, a in crossings if a is not None]
    if commanded_abc_rad is not None and len(abcs) == len(crossings):
        a_c = np.broadcast_to(np.asarray(commanded_abc_rad, dtype=float), (len(s), 3))
        dev = np.angle(np.exp(1j * (np.stack(abcs, axis=1) - a_c[:, None, :])))  # (m, n, 3)
        abar = dev.mean(axis=1)
        for k, name in enumerate("abc"):
            out[f"AT{name}_deg"] = float(np.rad2deg(np.abs(abar[:, k]).max()))
            spread = 3.0 * dev[:, :, k].std(axis=1, ddof=1) if n >= 2 else np.full(len(s), np.nan)
            out[f"RT{name}_deg"] = float(np.rad2deg(spread.max()))
    return out


# ---------------------------------------------------------------- 7.5


def corner_figures(path: Polyline, streams: Sequence[Stream]) -> dict[str, np.ndarray]:
    """Corner round-off error ``CR`` and corner overshoot ``CO`` (7.5), per corner and cycle.

    Parameters
    ----------
    path : Polyline
        The commanded path; its inner vertices are the corners.
    streams : sequence of Stream
        One attained path per cycle, base frame, mm.

    Returns
    -------
    dict of ndarray
        ``CR_mm`` and ``CO_mm``, shape (corners, n): per corner and cycle.
        ``CR`` is ``min_k |p_k - C|`` over the attained samples, refined to
        the nearest point of the polyline through them. ``CO`` is the
        largest ``(p - C) . e_out`` over the samples that have turned into
        the second segment (``0 <= (p - C) . u_2 <= L_2``), where ``u_2`` is
        its direction, ``L_2`` its length and ``e_out`` the unit vector
        normal to ``u_2`` in the corner's plane pointing away from the
        inside of the corner; 0 when the arm never crosses the second
        segment's line outwards. ``CR_max_mm`` and ``CO_max_mm`` (corners,)
        are the worst cycle of each corner.
    """
    v = path.vertices_mm
    if len(v) < 3:
        raise PathError("corner figures need a path with at least one corner")
    corner = v[1:-1]  # (C, 3)
    u1 = v[1:-1] - v[:-2]
    u2 = v[2:] - v[1:-1]
    l2 = np.linalg.norm(u2, axis=1)
    u1 /= np.linalg.norm(u1, axis=1, keepdims=True)
    u2 /= l2[:, None]
    e_out = u1 - np.einsum("cj,cj->c", u1, u2)[:, None] * u2
    norm = np.linalg.norm(e_out, axis=1)
    if np.any(norm < 1e-9):
        raise PathError("a corner with collinear segments has no round-off or overshoot")
    e_out /= norm[:, None]
    cr = np.empty((len(corner), len(streams)))
    co = np.empty_like(cr)
    for j, st in enumerate(streams):  # cycles differ in sample count
        rel = st.p_mm[None, :, :] - corner[:, None, :]  # (C, K, 3)
        cr[:, j] = _polyline_distance(rel)
        along = np.einsum("ckj,cj->ck", rel, u2)
        out = np.einsum("ckj,cj->ck", rel, e_out)
        turned = (along >= 0.0) & (along <= l2[:, None])
        co[:, j] = np.clip(np.where(turned, out, -np.inf).max(axis=1), 0.0, None)
    return {"CR_mm": cr, "CO_mm": co, "CR_max_mm": cr.max(axis=1), "CO_max_mm": co.max(axis=1)}


def _polyline_distance(rel: np.ndarray) -> np.ndarray:
    """Distance from the origin to the polyline through ``rel`` (C, K, 3), per row: (C,)."""
    a, b = rel[:, :-1, :], rel[:, 1:, :]
    ab = b - a
    w = np.clip(
        -np.einsum("ckj,ckj->ck", a, ab) / np.maximum(np.einsum("ckj,ckj->ck", ab, ab), 1e-300),
        0,
        1,
    )
    return np.linalg.norm(a + w[..., None] * ab, axis=2).min(axis=1)


# ---------------------------------------------------------------- 7.6


def path_speeds(stream: Stream, step: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Path speed over chords ``step`` samples long: mid times (K-step,), s, speeds, mm/s.

    A longer chord divides the tracker's noise by a longer time (at 500 Hz a
    10 um noise alone swings single-step speeds by several mm/s) at the cost
    of smoothing ripples faster than the chord.
    """
    if step < 1 or step >= len(stream.t_s):
        raise PathError(
            f"a speed chord of {step} samples does not fit a stream of {len(stream.t_s)}"
        )
    t, p = stream.t_s, stream.p_mm
    dt = t[step:] - t[:-step]
    return 0.5 * (t[step:] + t[:-step]), np.linalg.norm(p[step:] - p[:-step], axis=1) / dt


def velocity_figures(
    path: CommandedPath,
    streams: Sequence[Stream],
    v_c_mm_s: float,
    stretch_mm: tuple[float, float] | None = None,
    step: int = 1,
) -> dict:
    """Path velocity accuracy ``AV``, repeatability ``RV`` and fluctuation ``FV`` (7.6).

    Parameters
    ----------
    path : Polyline or Circle
        The commanded path (to know where each sample is along it).
    streams : sequence of Stream
        One attained path per cycle, base frame, mm and s.
    v_c_mm_s : float
        Commanded path speed, mm/s (> 0).
    stretch_mm : (float, float), optional
        Arc lengths between which the speed is meant to be constant (the
        standard measures away from the acceleration at the start and the
        braking at the end), mm; the whole path by default.
    step : int
        Samples per speed chord (:func:`path_speeds`).

    Returns
    -------
    dict
        ``AV_pct``, ``RV_pct`` (NaN for one cycle), ``FV_mm_s``, and per
        cycle ``vbar_mm_s`` (n,) and ``fluctuation_mm_s`` (n,).
    """
    if not v_c_mm_s > 0:
        raise PathError(f"the commanded speed must be > 0 mm/s, got {v_c_mm_s}")
    lo, hi = stretch_mm if stretch_mm is not None else (0.0, path.length_mm)
    vbar = np.empty(len(streams))
    fv = np.empty(len(streams))
    for j, st in enumerate(streams):
        _, v = path_speeds(st, step)
        mid = 0.5 * (st.p_mm[step:] + st.p_mm[:-step])
        s = path_parameter(path, mid)
        inside = (s >= lo) & (s <= hi)
        if inside.sum() < 2:
            raise PathError(f"cycle {j + 1} has fewer than 2 speed samples in {lo}..{hi} mm")
        vbar[j], fv[j] = v[inside].mean(), np.ptp(v[inside])
    mean = vbar.mean()
    rv = 3.0 * vbar.std(ddof=1) / v_c_mm_s * 100.0 if len(vbar) >= 2 else float("nan")
    return {
        "AV_pct": float((mean - v_c_mm_s) / v_c_mm_s * 100.0),
        "RV_pct": float(rv),
        "FV_mm_s": float(fv.max()),
        "vbar_mm_s": vbar,
        "fluctuation_mm_s": fv,
    }


# ---------------------------------------------------------------- time alignment

Reference = Callable[[np.ndarray], np.ndarray]


def stream_reference(t_s: npt.ArrayLike, p_mm: npt.ArrayLike) -> Reference:
    """Positions of a robot stream at any time, linear between its samples.

    Parameters
    ----------
    t_s : array_like, shape (R,)
        The robot's time stamps, s, increasing (its own clock).
    p_mm : array_like, shape (R, 3)
        Positions the controller reports (forward kinematics of its joints),
        base frame, mm.

    Returns
    -------
    callable
        ``f(t)`` with ``t`` shape (K,) giving shape (K, 3); held at the ends.
    """
    t = np.asarray(t_s, dtype=float)
    p = np.asarray(p_mm, dtype=float)

    def at(times: np.ndarray) -> np.ndarray:
        return np.stack([np.interp(times, t, p[:, k]) for k in range(3)], axis=-1)

    return at


def commanded_reference(path: CommandedPath, v_c_mm_s: float, t0_s: float = 0.0) -> Reference:
    """The commanded path run at constant speed from ``t0_s``: ``f(t) = x_c(v_c (t - t0))``.

    For a tracker-only alignment (no robot stream): the latency found
    against it is the start time of the motion on the tracker's clock,
    less ``t0_s``.
    """

    def at(times: np.ndarray) -> np.ndarray:
        s = np.clip(v_c_mm_s * (np.asarray(times, dtype=float) - t0_s), 0.0, path.length_mm)
        return path.point(s)

    return at


def estimate_latency(
    t_s: npt.ArrayLike,
    p_mm: npt.ArrayLike,
    reference: Reference,
    max_latency_s: float,
    resolution_s: float = 1e-3,
) -> float:
    """Constant latency of a measured stream behind a reference, by least squares.

    Finds ``tau`` minimising ``sum_k |p_k - reference(t_k - tau)|^2``: a grid
    over ``[-max_latency_s, max_latency_s]`` at ``resolution_s`` (the
    discrete cross-correlation, vectorised over trial latencies), then a
    bounded scalar minimisation around the best grid point.

    Parameters
    ----------
    t_s : array_like, shape (K,)
        Time stamps of the measured (tracker) stream, s, on its clock.
    p_mm : array_like, shape (K, 3)
        Measured positions, the reference's frame, mm.
    reference : callable
        Positions the reference says the target had at given times, (K,) -> (K, 3)
        (:func:`stream_reference`, :func:`commanded_reference`).
    max_latency_s : float
        Largest latency looked for, either sign, s.
    resolution_s : float
        Grid step, s; the result is refined below it.

    Returns
    -------
    float
        ``tau``, s: a positive value means a reading stamped ``t`` shows where
        the reference put the target at ``t - tau``.
    """
    t = np.asarray(t_s, dtype=float)
    p = np.asarray(p_mm, dtype=float)
    if t.ndim != 1 or p.shape != (len(t), 3) or len(t) < 2:
        raise PathError(f"latency needs t_s (K >= 2,) and p_mm (K, 3), got {t.shape}, {p.shape}")
    if not (max_latency_s > 0 and resolution_s > 0):
        raise PathError("max_latency_s and resolution_s must be > 0")
    grid = np.arange(-max_latency_s, max_latency_s + 0.5 * resolution_s, resolution_s)
    # The grid only has to land next to the minimum: an even subset of the samples does.
    sub = np.linspace(0, len(t) - 1, min(len(t), _GRID_SAMPLES)).astype(int)
    ts, ps = t[sub], p[sub]
    shifted = reference((ts[None, :] - grid[:, None]).ravel()).reshape(len(grid), len(ts), 3)
    cost = ((shifted - ps[None]) ** 2).sum(axis=(1, 2))
    g = int(np.argmin(cost))

    def sse(tau: float) -> float:
        return float(((reference(t - tau) - p) ** 2).sum())

    lo, hi = grid[max(g - 1, 0)], grid[min(g + 1, len(grid) - 1)]
    if hi <= lo:
        return float(grid[g])
    res = minimize_scalar(sse, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7})
    return float(res.x)
