"""The study's statistics against numpy on trial errors the test draws itself.

``Summary`` folds trial errors into histograms and per-block sums, and
``statistics`` reads the study's numbers back from them. Here the trial
errors are drawn directly (no arm), so every number has an independent
reference: ``np.median``, ``np.std``, moments of the raw samples, and the
known shape of a Gaussian kernel.
"""

import math

import numpy as np
import pytest

from calibrator.analysis import misalignment as mc


def _grid(r_max=4.0):
    return mc.Grid(
        r_max=r_max,
        xyz_lo=np.full(3, -3.0),
        xyz_hi=np.full(3, 3.0),
        rot_lo=np.full(3, -0.02),
        rot_hi=np.full(3, 0.02),
        axis_hi=0.05,
    )


def _trials(seed, n):
    rng = np.random.default_rng(seed)
    dp = rng.normal([0.3, -0.2, 0.1], [0.5, 0.4, 0.3], size=(n, 3))
    rotvec = rng.normal([0.001, -0.002, 0.0], [0.003, 0.002, 0.004], size=(n, 3))
    axis = np.abs(rng.normal(0.0, 0.01, size=(n, 3)))
    return dp, rotvec, axis


def _summary(grid, blocks):
    summary = mc.Summary()
    for k, (dp, rotvec, axis) in enumerate(blocks):
        summary.add_block(k, dp, rotvec, axis, grid)
    return summary


@pytest.fixture
def study():
    grid = _grid()
    blocks = [_trials(seed, 20_000) for seed in (1, 2)]
    return grid, blocks, _summary(grid, blocks)


def test_statistics_equal_numpy_on_the_raw_trials(study):
    grid, blocks, summary = study
    dp = np.concatenate([b[0] for b in blocks])
    rotvec = np.concatenate([b[1] for b in blocks])
    axis = np.concatenate([b[2] for b in blocks])
    r = np.linalg.norm(dp, axis=1)
    stats = mc.statistics(summary, grid)
    bin_mm = grid.r_max / mc.N_RADIAL_BINS

    assert stats["trials"] == len(r) == summary.count
    pos = stats["position"]
    assert pos["max"] == pytest.approx(r.max(), abs=0, rel=1e-15)
    assert pos["mean"] == pytest.approx(r.mean(), rel=1e-12)
    assert pos["rms"] == pytest.approx(math.sqrt(np.mean(r * r)), rel=1e-12)
    np.testing.assert_allclose(pos["mean_vector"], dp.mean(axis=0), rtol=1e-10)
    np.testing.assert_allclose(pos["std_vector"], dp.std(axis=0), rtol=1e-9)
    # Quantiles from the binned CDF: within a bin of numpy's on the samples
    # that fall inside the |dP| range (a few beyond it are counted, not binned).
    inside = r < grid.r_max
    for p, key in ((50, "cdf50"), (90, "cdf90"), (98, "cdf98")):
        assert pos[key] == pytest.approx(np.percentile(r, p), abs=2 * bin_mm)
    iqr = np.percentile(r, 75) - np.percentile(r, 25)
    assert pos["kernel"] == pytest.approx(2.0 * iqr * len(r) ** (-1 / 3), rel=1e-3)
    assert stats["outside"]["radial"] == np.count_nonzero(~inside)

    for j, name in enumerate("xyz"):
        o = stats["orientation_deg"][name]
        assert o["mean"] == pytest.approx(math.degrees(rotvec[:, j].mean()), rel=1e-9)
        assert o["std"] == pytest.approx(math.degrees(rotvec[:, j].std()), rel=1e-9)
        assert o["max_abs"] == pytest.approx(math.degrees(np.abs(rotvec[:, j]).max()), rel=1e-15)
        assert o["axis_angle_max"] == pytest.approx(math.degrees(axis[:, j].max()), rel=1e-15)
        axis_bin_deg = math.degrees(grid.axis_hi / mc.N_ANGLE_BINS)
        median = math.degrees(np.median(axis[:, j]))
        assert o["axis_angle_median"] == pytest.approx(median, abs=axis_bin_deg)


def test_outside_counts_each_range_separately():
    grid = _grid(r_max=1.0)
    dp = np.array([[0.5, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 5.0], [0.1, 0.1, 0.1]])
    rotvec = np.array([[0.0, 0.0, 0.0], [0.03, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, -0.5, 0.0]])
    axis = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.06, 0.0], [0.0, 0.0, 0.0]])
    summary = _summary(grid, [(dp, rotvec, axis)])
    # |dP|: 2.0 and 5.0 are beyond r_max = 1. XY: only the 2.0 in x lies
    # beyond +-3; XZ and YZ: the 2.0 in x (XZ) and the 5.0 in z (both).
    # Orientation: 0.03 and -0.5 beyond +-0.02, and one axis angle beyond 0.05.
    np.testing.assert_array_equal(summary.outside, [2, 0, 1, 1, 3])
    assert summary.hist_r.sum() == 2
    assert summary.maps[0].sum() == 4 and summary.maps[1].sum() == 3
    assert summary.hist_rot.sum() == 3 * 4 - 2 and summary.hist_axis.sum() == 3 * 4 - 1


def test_maps_put_each_trial_in_its_cell():
    grid = _grid()
    dp = np.array([[-2.99, 0.0, 2.99]])
    summary = _summary(grid, [(dp, np.zeros((1, 3)), np.zeros((1, 3)))])
    cell = lambda v: int((v + 3.0) / 6.0 * mc.N_GRID)  # noqa: E731
    # XY plane: row from x, column from y; XZ: x, z; YZ: y, z.
    assert summary.maps[0][cell(-2.99), cell(0.0)] == 1
    assert summary.maps[1][cell(-2.99), cell(2.99)] == 1
    assert summary.maps[2][cell(0.0), cell(2.99)] == 1
    assert summary.hist_rot[:, mc.N_ANGLE_BINS // 2].tolist() == [1, 1, 1]
    assert summary.hist_axis[:, 0].tolist() == [1, 1, 1]


def test_unsmoothed_density_is_the_histogram_per_mm():
    grid = _grid(r_max=2.0)
    summary = mc.Summary(count=8)
    summary.hist_r[10], summary.hist_r[500] = 3, 5
    centres, dens = mc.radial_density(summary, grid, 0.0)
    width = grid.r_max / mc.N_RADIAL_BINS
    assert len(dens) == mc.N_RADIAL_BINS
    np.testing.assert_allclose(centres[[0, 10, 500]], (np.array([0, 10, 500]) + 0.5) * width)
    assert dens[10] == pytest.approx(3 / 8 / width) and dens[500] == pytest.approx(5 / 8 / width)
    assert np.count_nonzero(dens) == 2


@pytest.mark.parametrize("kernel_bins, merged", [(7.9, 1), (8.0, 2), (64.0, 16), (4000.0, 256)])
def test_smoothed_density_is_a_unit_gaussian_of_the_kernel_width(kernel_bins, merged):
    grid = _grid(r_max=2.0)
    width = grid.r_max / mc.N_RADIAL_BINS
    kernel_mm = kernel_bins * width
    summary = mc.Summary(count=1)
    spike = mc.N_RADIAL_BINS // 2
    summary.hist_r[spike] = 1
    centres, dens = mc.radial_density(summary, grid, kernel_mm)
    # Bins are merged by the largest power of two <= kernel / 4 bins, at most 256
    # (4000 bins would allow 512).
    assert len(dens) == mc.N_RADIAL_BINS // merged
    step = centres[1] - centres[0]
    assert step == pytest.approx(width * merged)
    assert dens.sum() * step == pytest.approx(1.0, rel=1e-6)
    mean = np.sum(centres * dens) * step
    spread = math.sqrt(np.sum((centres - mean) ** 2 * dens) * step)
    assert mean == pytest.approx((spike + 0.5) * width, abs=step)
    # A spike smoothed by a Gaussian of sigma = kernel, plus the bins' own width.
    assert spread == pytest.approx(math.hypot(kernel_mm, step / math.sqrt(12)), rel=0.02)


@pytest.mark.parametrize("n", [1, 5, 40, 4096])
@pytest.mark.parametrize("sigma", [0.1, 0.37, 2.0, 11.5, 300.0])
def test_smoothing_is_scipys_gaussian_filter_with_zeros_outside(n, sigma):
    # The kernel longer than the data (n=1, 5 against sigma 300) included.
    from scipy.ndimage import gaussian_filter1d

    values = np.random.default_rng(n).random(n)
    expected = gaussian_filter1d(values, sigma, mode="constant")
    np.testing.assert_allclose(mc._gaussian_smooth(values, sigma), expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("angle", [1e-9, 0.02, 1.0, 2.5])
def test_hand_errors_of_a_known_rotation_and_offset(angle):
    # Real hand = ideal hand turned by a known rotation (hand frame) and moved by a
    # known offset (base frame): the errors are exactly those, checked with scipy.
    from scipy.spatial.transform import Rotation

    from calibrator.analysis import arm as arm_module

    arm = arm_module.build()
    ideal = arm.base2hand()
    axes = np.array([[0.3, -0.5, 0.8], [1.0, 0.0, 0.0], [-0.2, 0.9, 0.4]])
    turns = Rotation.from_rotvec(angle * axes / np.linalg.norm(axes, axis=1, keepdims=True))
    offsets = np.array([[0.1, -0.2, 0.3], [0.0, 0.0, 0.0], [-1.5, 2.0, 0.25]])
    real = np.empty((3, 3, 4))
    real[:, :, :3] = ideal[:, :3] @ turns.as_matrix()
    real[:, :, 3] = ideal[:, 3] + offsets
    dp, rotvec, axis_angle = mc.hand_errors(arm, real)
    np.testing.assert_allclose(dp, offsets, atol=1e-12)
    np.testing.assert_allclose(rotvec, turns.as_rotvec(), rtol=1e-7, atol=1e-15)
    # angle between real and ideal hand axis k: arccos of (R_ideal^T R_real)[k, k]
    expected = np.array(
        [
            [
                np.arctan2(np.linalg.norm(np.cross(e, m[:, k])), m[k, k])
                for k, e in enumerate(np.eye(3))
            ]
            for m in turns.as_matrix()
        ]
    )
    np.testing.assert_allclose(axis_angle, expected, rtol=1e-7, atol=1e-15)
