"""Joint-axis misalignment Monte Carlo (the misalignment paper): hand error from bearing clearances.

Model
-----
Joint i's real axis crosses the joint's two end faces, ``h_i`` apart, at
``P1 = (R1, phi1)`` and ``P2 = (R2, phi2)``, each uniform over a disk of
radius ``R0_i`` (``R = R0 sqrt(u)``, ``phi = 2 pi u``). The joint frame is
replaced by ``joint frame . E_i`` with::

    E_i = Trans(R2 cos phi2, R2 sin phi2, 0) . Rx(omega) . Ry(theta)
    tan omega = (R1 sin phi1 - R2 sin phi2) / h
    tan theta = (R1 cos phi1 - R2 cos phi2) / sqrt((R1 sin phi1 - R2 sin phi2)^2 + h^2)

(the paper's equations 5-13, its sign of omega included: the distribution
is symmetric in it), so the real chain is ``L_1 E_1 L_2 E_2 ... L_6 E_6 F``
(:mod:`calibrator.analysis.arm`).

Per trial the outputs are the hand position error ``dP = P_real - P_ideal``
(mm, base frame) and the orientation error ``R_ideal^T R_real`` (hand
frame), given as its rotation vector (signed angles about the hand's x, y,
z) and as the angle between each real hand axis and its ideal direction
(the paper's "angle between the axes").

Reproducibility
---------------
Trials are cut into fixed blocks of :data:`BLOCK` trials. Block k draws from
its own stream ``SeedSequence(seed, spawn_key=(k,))``, which is exactly the
k-th child of ``SeedSequence(seed).spawn(...)``. A task (chunk) is any set
of whole blocks; it returns integer histograms (summed exactly in any order),
maxima, and float sums *per block*, which are added in block order at the
end. So the result depends only on ``(seed, trials)``, never on how blocks
are grouped into chunks or which worker ran them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

# Loaded now, with this module, not lazily at the first block: a Ctrl-C that lands
# while numpy.random's compiled modules load is swallowed inside their set-up, and
# the run went on for minutes (1 run in 6-12 interrupted right after its first line).
import numpy.random  # noqa: F401,I001

from calibrator.analysis import _malloc
from calibrator.analysis.arm import PosedArm, compose
from calibrator.errors import CalibrationError

#: Trials per random stream. Part of the definition of a seeded result:
#: changing it changes the numbers drawn for a seed.
BLOCK = 10_000
#: Bins of the fine |dP| histogram quantiles are read from.
N_RADIAL_BINS = 1 << 16
#: Bins per axis of the density maps and the orientation densities.
N_GRID = 160
N_ANGLE_BINS = 200
#: Distance between the end faces (mm) used for the paper's arm, which does
#: not give it: the value at which the median |dP| at R0 = 0.05 mm equals the
#: paper's 0.44 mm (fitted on 200,000 trials, seed 0, by
#: ``benchmarks/analyze_paper.py``). Nothing else was fitted.
PAPER_H_MM = 267.0
_SUM_COLUMNS = 14  # dP (3), dP^2 (3), rotation vector (3), its square (3), |dP|, |dP|^2


@dataclass(frozen=True)
class Study:
    """One Monte Carlo study.

    Attributes
    ----------
    arm : PosedArm
        The arm at its pose.
    r0_mm : ndarray, shape (6,)
        Maximum radial clearance of each joint (mm); 0 switches a joint's error off.
    h_mm : ndarray, shape (6,)
        Distance between each joint's two end faces (mm), > 0.
    trials : int
    seed : int
    """

    arm: PosedArm
    r0_mm: np.ndarray
    h_mm: np.ndarray
    trials: int
    seed: int = 0

    def __post_init__(self):
        r0 = np.broadcast_to(np.asarray(self.r0_mm, dtype=float), (6,)).copy()
        h = np.broadcast_to(np.asarray(self.h_mm, dtype=float), (6,)).copy()
        if not (np.all(np.isfinite(r0)) and np.all(r0 >= 0)):
            raise CalibrationError("R0 must be finite and >= 0 mm for every joint")
        if not (np.all(np.isfinite(h)) and np.all(h > 0)):
            raise CalibrationError("h must be finite and > 0 mm for every joint")
        if int(self.trials) < 1:
            raise CalibrationError(f"trials must be >= 1, got {self.trials}")
        if not 0 <= int(self.seed) <= MAX_SEED:
            # SeedSequence raises a bare ValueError on a negative seed.
            raise CalibrationError(f"seed must be in [0, 2**63 - 1], got {self.seed}")
        object.__setattr__(self, "r0_mm", r0)
        object.__setattr__(self, "h_mm", h)
        object.__setattr__(self, "trials", int(self.trials))

    @property
    def n_blocks(self) -> int:
        return -(-self.trials // BLOCK)

    def block_size(self, k: int) -> int:
        """Number of trials in block ``k``."""
        return min(BLOCK, self.trials - k * BLOCK)


#: Largest seed: a 64-bit signed integer, as every seed of the project.
MAX_SEED = 2**63 - 1


def block_rng(seed: int, k: int) -> np.random.Generator:
    """The random generator of block ``k``: the k-th child of ``SeedSequence(seed)``."""
    return np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(k,)))


def error_transforms(
    rng: np.random.Generator, n: int, r0_mm: np.ndarray, h_mm: np.ndarray
) -> np.ndarray:
    """Draw ``n`` sets of the six joints' error transforms E_i.

    Parameters
    ----------
    rng : numpy.random.Generator
    n : int
    r0_mm, h_mm : ndarray, shape (6,)

    Returns
    -------
    ndarray, shape (n, 6, 3, 4)
        Top rows of E_i, joint frame to misaligned joint frame (mm).
    """
    u = rng.random((n, 6, 4))
    r1 = r0_mm * np.sqrt(u[..., 0])
    phi1 = 2.0 * np.pi * u[..., 1]
    r2 = r0_mm * np.sqrt(u[..., 2])
    phi2 = 2.0 * np.pi * u[..., 3]
    x2, y2 = r2 * np.cos(phi2), r2 * np.sin(phi2)
    dx = r1 * np.cos(phi1) - x2
    dy = r1 * np.sin(phi1) - y2
    omega = np.arctan(dy / h_mm)
    theta = np.arctan(dx / np.sqrt(dy * dy + h_mm * h_mm))
    cw, sw = np.cos(omega), np.sin(omega)
    ct, st = np.cos(theta), np.sin(theta)
    e = np.zeros((n, 6, 3, 4))
    # Rx(omega) . Ry(theta), written out, then the offset of the axis.
    e[..., 0, 0], e[..., 0, 2] = ct, st
    e[..., 1, 0], e[..., 1, 1], e[..., 1, 2] = sw * st, cw, -sw * ct
    e[..., 2, 0], e[..., 2, 1], e[..., 2, 2] = -cw * st, sw, cw * ct
    e[..., 0, 3], e[..., 1, 3] = x2, y2
    return e


def real_hand(arm: PosedArm, errors: np.ndarray) -> np.ndarray:
    """Hand poses of the chain with the error transforms inserted.

    Parameters
    ----------
    arm : PosedArm
    errors : ndarray, shape (n, 6, 3, 4)

    Returns
    -------
    ndarray, shape (n, 3, 4)
        ``L_1 E_1 ... L_6 E_6 F`` (mm, base frame).
    """
    t = compose(arm.links[0], errors[:, 0])
    for i in range(1, 6):
        t = compose(compose(t, arm.links[i]), errors[:, i])
    return compose(t, arm.tail)


def hand_errors(arm: PosedArm, real: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position and orientation errors of real hand poses against the ideal one.

    Returns
    -------
    dp : ndarray, shape (n, 3)
        ``P_real - P_ideal`` (mm, base frame).
    rotvec : ndarray, shape (n, 3)
        Rotation vector of ``R_ideal^T R_real`` (rad, hand frame).
    axis_angle : ndarray, shape (n, 3)
        Angle between each real hand axis x, y, z and its ideal direction (rad).
    """
    ideal = arm.base2hand()
    dp = real[:, :, 3] - ideal[:, 3]
    r = np.einsum("ji,njk->nik", ideal[:, :3], real[:, :, :3])
    v = 0.5 * np.stack([r[:, 2, 1] - r[:, 1, 2], r[:, 0, 2] - r[:, 2, 0], r[:, 1, 0] - r[:, 0, 1]])
    sin_a = np.sqrt(np.sum(v * v, axis=0))
    angle = np.arctan2(sin_a, 0.5 * (r[:, 0, 0] + r[:, 1, 1] + r[:, 2, 2] - 1.0))
    # angle / sin(angle) -> 1 as the rotation vanishes.
    scale = np.divide(angle, sin_a, out=np.ones_like(angle), where=sin_a > 0)
    rotvec = (v * scale).T
    # |e_k x r_k| and e_k . r_k for the k-th column r_k of r. The cross product's
    # size is taken from the column's off-diagonal entries, not as sqrt(1 - r_kk^2),
    # which cancels to 0 below ~1e-8 rad.
    diag = np.stack([r[:, 0, 0], r[:, 1, 1], r[:, 2, 2]], axis=1)
    off = np.sqrt(np.einsum("nik,ik->nk", r * r, 1.0 - np.eye(3)))
    return dp, rotvec, np.arctan2(off, diag)


def simulate_block(study: Study, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Errors of block ``k`` of a study: :func:`hand_errors` of its trials."""
    rng = block_rng(study.seed, k)
    errors = error_transforms(rng, study.block_size(k), study.r0_mm, study.h_mm)
    return hand_errors(study.arm, real_hand(study.arm, errors))


@dataclass(frozen=True)
class Grid:
    """Histogram ranges, fixed before the run so every chunk bins alike.

    Attributes
    ----------
    r_max : float
        Upper end of the |dP| histogram (mm), an upper bound of |dP|.
    xyz_lo, xyz_hi : ndarray, shape (3,)
        Ranges of the dP density maps (mm).
    rot_lo, rot_hi : ndarray, shape (3,)
        Ranges of the rotation-vector densities (rad).
    axis_hi : float
        Upper end of the axis-angle densities (rad).
    """

    r_max: float
    xyz_lo: np.ndarray
    xyz_hi: np.ndarray
    rot_lo: np.ndarray
    rot_hi: np.ndarray
    axis_hi: float


def make_grid(
    study: Study, block0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
) -> Grid:
    """Histogram ranges for a study: a bound for |dP|, and display ranges from block 0.

    ``block0`` is :func:`simulate_block` ``(study, 0)`` if the caller has it
    already (it is simulated otherwise).

    The |dP| range must hold every trial, so it comes from a bound: each
    joint moves the hand by at most its offset R0 plus its tilt
    (<= 2 R0 / h) times the distance from the joint to the hand, with 50 %
    margin for second-order terms. The density maps only need to frame the
    cloud, so they use the mean +- 6 standard deviations of block 0 (a
    deterministic function of the seed); trials outside are counted.
    """
    frames = study.arm.joint_frames()
    hand = study.arm.base2hand()[:, 3]
    lever = np.linalg.norm(hand - frames[:, :, 3], axis=1)
    tilt = 2.0 * study.r0_mm / study.h_mm
    bound = 1.5 * float(np.sum(study.r0_mm + tilt * (lever + study.r0_mm)))
    dp, rotvec, axis = simulate_block(study, 0) if block0 is None else block0

    def span(x):
        mid, half = x.mean(axis=0), 6.0 * x.std(axis=0)
        half = np.maximum(half, 1e-12 + 1e-9 * np.abs(mid))
        return mid - half, mid + half

    xyz_lo, xyz_hi = span(dp)
    rot_lo, rot_hi = span(rotvec)
    return Grid(
        r_max=max(bound, 1e-12),
        xyz_lo=xyz_lo,
        xyz_hi=xyz_hi,
        rot_lo=rot_lo,
        rot_hi=rot_hi,
        axis_hi=max(2.0 * float(axis.max()), 1e-15),
    )


def _bin(x, lo, hi, n):
    """Bin index of each value in ``[lo, hi)`` split in ``n``; -1 outside."""
    idx = np.floor((x - lo) * (n / (hi - lo))).astype(np.int64)
    idx[(idx < 0) | (idx >= n)] = -1
    return idx


@dataclass
class Summary:
    """What chunks return and how they merge: counts, maxima, per-block sums.

    Attributes
    ----------
    count : int
    hist_r : ndarray of int64, shape (N_RADIAL_BINS,)
        |dP| over ``[0, grid.r_max)``.
    maps : ndarray of int64, shape (3, N_GRID, N_GRID)
        dP density maps on the XY, XZ, YZ planes (rows: first axis).
    hist_rot, hist_axis : ndarray of int64, shape (3, N_ANGLE_BINS)
        Rotation-vector components and axis angles.
    outside : ndarray of int64, shape (5,)
        Trials outside the |dP|, XY, XZ, YZ and orientation ranges.
    max_r : float
        Largest |dP| (mm).
    max_abs_rot, max_axis : ndarray, shape (3,)
        Largest |rotation-vector component| and axis angle (rad).
    sums : dict of int to ndarray, shape (14,)
        Float sums of each block, keyed by block index.
    """

    count: int = 0
    hist_r: np.ndarray = field(default_factory=lambda: np.zeros(N_RADIAL_BINS, np.int64))
    maps: np.ndarray = field(default_factory=lambda: np.zeros((3, N_GRID, N_GRID), np.int64))
    hist_rot: np.ndarray = field(default_factory=lambda: np.zeros((3, N_ANGLE_BINS), np.int64))
    hist_axis: np.ndarray = field(default_factory=lambda: np.zeros((3, N_ANGLE_BINS), np.int64))
    outside: np.ndarray = field(default_factory=lambda: np.zeros(5, np.int64))
    max_r: float = 0.0
    max_abs_rot: np.ndarray = field(default_factory=lambda: np.zeros(3))
    max_axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    sums: dict = field(default_factory=dict)

    def add_block(
        self, k: int, dp: np.ndarray, rotvec: np.ndarray, axis: np.ndarray, grid: Grid
    ) -> None:
        """Fold one block's trial errors in."""
        r = np.sqrt(np.sum(dp * dp, axis=1))
        self.count += len(r)
        self.max_r = max(self.max_r, float(r.max()))
        self.max_abs_rot = np.maximum(self.max_abs_rot, np.abs(rotvec).max(axis=0))
        self.max_axis = np.maximum(self.max_axis, axis.max(axis=0))
        idx = _bin(r, 0.0, grid.r_max, N_RADIAL_BINS)
        self.outside[0] += np.count_nonzero(idx < 0)
        self.hist_r += np.bincount(idx[idx >= 0], minlength=N_RADIAL_BINS)
        cells = [_bin(dp[:, j], grid.xyz_lo[j], grid.xyz_hi[j], N_GRID) for j in range(3)]
        for m, (a, b) in enumerate(((0, 1), (0, 2), (1, 2))):
            ok = (cells[a] >= 0) & (cells[b] >= 0)
            self.outside[1 + m] += np.count_nonzero(~ok)
            flat = cells[a][ok] * N_GRID + cells[b][ok]
            self.maps[m] += np.bincount(flat, minlength=N_GRID * N_GRID).reshape(N_GRID, N_GRID)
        for j in range(3):
            ir = _bin(rotvec[:, j], grid.rot_lo[j], grid.rot_hi[j], N_ANGLE_BINS)
            ia = _bin(axis[:, j], 0.0, grid.axis_hi, N_ANGLE_BINS)
            self.outside[4] += np.count_nonzero(ir < 0) + np.count_nonzero(ia < 0)
            self.hist_rot[j] += np.bincount(ir[ir >= 0], minlength=N_ANGLE_BINS)
            self.hist_axis[j] += np.bincount(ia[ia >= 0], minlength=N_ANGLE_BINS)
        self.sums[k] = np.concatenate(
            [dp.sum(0), (dp * dp).sum(0), rotvec.sum(0), (rotvec * rotvec).sum(0)]
            + [[r.sum(), (r * r).sum()]]
        )

    def merge(self, other: Summary) -> Summary:
        """Add another chunk's summary (exact: integers, maxima, per-block sums)."""
        self.count += other.count
        for name in ("hist_r", "maps", "hist_rot", "hist_axis", "outside"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.max_r = max(self.max_r, other.max_r)
        self.max_abs_rot = np.maximum(self.max_abs_rot, other.max_abs_rot)
        self.max_axis = np.maximum(self.max_axis, other.max_axis)
        self.sums.update(other.sums)
        return self

    def totals(self) -> np.ndarray:
        """The float sums over all blocks, added in block order, shape (14,)."""
        rows = np.array([self.sums[k] for k in sorted(self.sums)]).reshape(-1, _SUM_COLUMNS)
        return np.array([math.fsum(col) for col in rows.T])


def first_block(study: Study) -> tuple[Grid, Summary]:
    """The study's grid, and the summary of block 0, which its ranges are drawn from.

    Block 0 is simulated once, for both; the unit of work that starts a run
    (in the calling process, or in the helper of ``_spare``).
    """
    _malloc.keep_freed_memory()  # in whichever process runs it, as run_chunk
    block = simulate_block(study, 0)
    grid = make_grid(study, block)
    summary = Summary()
    summary.add_block(0, *block, grid)
    return grid, summary


def run_chunk(study: Study, grid: Grid, blocks: Sequence[int]) -> Summary:
    """Simulate whole blocks and summarise them: the unit of work sent to a worker.

    Parameters
    ----------
    study : Study
    grid : Grid
    blocks : sequence of int
        Block indices.

    Returns
    -------
    Summary
    """
    _malloc.keep_freed_memory()  # in whichever process runs it: caller or worker
    summary = Summary()
    for k in blocks:
        summary.add_block(k, *simulate_block(study, k), grid)
    return summary


def _quantile(cdf, edges, p):
    """Value at which the binned CDF reaches ``p``, linear inside the bin."""
    i = int(np.searchsorted(cdf, p, side="left"))
    i = min(i, len(cdf) - 1)
    lo = cdf[i - 1] if i > 0 else 0.0
    frac = 0.0 if cdf[i] == lo else (p - lo) / (cdf[i] - lo)
    return float(edges[i] + frac * (edges[i + 1] - edges[i]))


def radial_density(summary: Summary, grid: Grid, kernel_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Density of |dP| (1/mm), smoothed by a Gaussian kernel of ``kernel_mm``.

    The fine histogram is first merged by a power of two so that the kernel
    spans at least 4 bins: smoothing then costs a few taps per bin, and the
    bins stay well under the kernel width.

    Returns
    -------
    centres, density : ndarray, shape (N_RADIAL_BINS // f,)
        Bin centres (mm) and density (1/mm).
    """
    sigma = kernel_mm / (grid.r_max / N_RADIAL_BINS)
    f = 1
    while f * 2 <= sigma / 4 and f * 2 <= N_RADIAL_BINS // 256:
        f *= 2
    width = grid.r_max / N_RADIAL_BINS * f
    dens = summary.hist_r.reshape(-1, f).sum(axis=1) / max(summary.count, 1) / width
    if sigma > 0:
        dens = _gaussian_smooth(dens.astype(float), sigma / f)
    return (np.arange(len(dens)) + 0.5) * width, dens


def _gaussian_smooth(values: np.ndarray, sigma: float) -> np.ndarray:
    """``values`` (shape (N,)) convolved with a unit-sum Gaussian of ``sigma`` bins, zeros outside.

    The kernel is cut at 4 sigma, as ``scipy.ndimage.gaussian_filter1d``
    (``mode="constant"``) cuts it, whose result this equals to rounding; numpy
    alone, because importing ``scipy.ndimage`` cost every analysis about
    0.15 s, more than smoothing a few thousand bins.
    """
    radius = int(4.0 * sigma + 0.5)
    x = np.arange(-radius, radius + 1)
    weights = np.exp(-0.5 / (sigma * sigma) * x**2)
    weights /= weights.sum()
    return np.convolve(values, weights, mode="full")[radius : radius + len(values)]


def statistics(summary: Summary, grid: Grid) -> dict:
    """The study's numbers from a merged summary.

    Returns
    -------
    dict
        ``position`` (mm): ``pdf_peak`` (mode of the density smoothed by a
        Gaussian of width ``kernel``), ``cdf50``, ``cdf90``, ``cdf98``,
        ``max``, ``mean`` (|dP|), ``rms``, ``mean_vector`` (density-centre
        offset, base frame), ``std_vector``; ``orientation_deg``: per axis
        ``x, y, z`` the mean, std and largest magnitude of the rotation-vector
        component, and the median and largest axis angle; ``trials``;
        ``outside`` (trials outside each histogram range).
    """
    n = summary.count
    t = summary.totals()
    edges = np.linspace(0.0, grid.r_max, N_RADIAL_BINS + 1)
    cdf = np.cumsum(summary.hist_r) / n
    q = {p: _quantile(cdf, edges, p / 100.0) for p in (25, 50, 75, 90, 98)}
    # Kernel of the mode estimate: the Freedman-Diaconis width, from the binned IQR.
    kernel = 2.0 * (q[75] - q[25]) * n ** (-1.0 / 3.0)
    centres, dens = radial_density(summary, grid, kernel)
    peak = float(centres[int(np.argmax(dens))])
    mean_v, mean_sq = t[0:3] / n, t[3:6] / n
    rot_mean, rot_sq = t[6:9] / n, t[9:12] / n
    axis_edges = np.linspace(0.0, grid.axis_hi, N_ANGLE_BINS + 1)
    orient = {}
    for j, name in enumerate("xyz"):
        acdf = np.cumsum(summary.hist_axis[j]) / n
        orient[name] = {
            "mean": math.degrees(rot_mean[j]),
            "std": math.degrees(math.sqrt(max(rot_sq[j] - rot_mean[j] ** 2, 0.0))),
            "max_abs": math.degrees(summary.max_abs_rot[j]),
            "axis_angle_median": math.degrees(_quantile(acdf, axis_edges, 0.5)),
            "axis_angle_max": math.degrees(summary.max_axis[j]),
        }
    return {
        "trials": n,
        "position": {
            "pdf_peak": peak,
            "kernel": kernel,
            "cdf50": q[50],
            "cdf90": q[90],
            "cdf98": q[98],
            "max": summary.max_r,
            "mean": float(t[12] / n),
            "rms": math.sqrt(t[13] / n),
            "mean_vector": mean_v.tolist(),
            "std_vector": np.sqrt(np.maximum(mean_sq - mean_v**2, 0.0)).tolist(),
        },
        "orientation_deg": orient,
        "outside": dict(
            zip(("radial", "xy", "xz", "yz", "orientation"), map(int, summary.outside), strict=True)
        ),
    }
