"""Quantiles read from a binned CDF, on histograms small enough to interpolate by hand.

With the study's 65,536 radial bins a wrong interpolation moves a quantile by
less than one bin, far below what the statistical tests can see; here every
bin is 1 mm wide and the expected values are worked out in the comments.
"""

import numpy as np
import pytest

from calibrator.analysis import misalignment as mc

EDGES = [0.0, 1.0, 2.0, 3.0, 4.0]


@pytest.mark.parametrize(
    "cdf, p, expected",
    [
        # Bins [0,1) 20 %, [1,2) 30 %, [2,3) none, [3,4) 50 %.
        ([0.2, 0.5, 0.5, 1.0], 0.1, 0.5),  # half-way through the first bin's 20 %
        ([0.2, 0.5, 0.5, 1.0], 0.2, 1.0),  # the first bin's upper edge
        ([0.2, 0.5, 0.5, 1.0], 0.35, 1.5),  # 0.15 of the second bin's 0.3
        ([0.2, 0.5, 0.5, 1.0], 0.5, 2.0),  # reached at the end of bin 2, not after the gap
        ([0.2, 0.5, 0.5, 1.0], 0.75, 3.5),  # half of the last bin's 50 %
        ([0.2, 0.5, 0.5, 1.0], 1.0, 4.0),
        # Nothing in the first bins: the quantile 0 is the lower edge.
        ([0.0, 0.0, 0.6, 1.0], 0.0, 0.0),
        ([0.0, 0.0, 0.6, 1.0], 0.3, 2.5),
        # 10 % of the trials beyond the range: the 98 % point lies beyond it too,
        # on the last bin's slope (0.2 per mm): 3 + (0.98 - 0.7) / 0.2.
        ([0.2, 0.5, 0.7, 0.9], 0.98, 4.4),
    ],
)
def test_quantile_interpolates_linearly_inside_the_bin(cdf, p, expected):
    assert mc._quantile(cdf, EDGES, p) == pytest.approx(expected, abs=1e-12)


def test_bins_of_values_in_and_outside_the_range():
    # Four 0.25-wide bins over [0, 1); the upper end itself is outside.
    x = np.array([-0.1, 0.0, 0.26, 0.5, 0.999, 1.0, 1.5])
    np.testing.assert_array_equal(mc._bin(x, 0.0, 1.0, 4), [-1, 0, 1, 2, 3, -1, -1])


def test_each_block_draws_from_its_own_spawned_stream():
    children = np.random.SeedSequence(42).spawn(3)
    draws = [mc.block_rng(42, k).random(5) for k in range(3)]
    for k, child in enumerate(children):
        np.testing.assert_array_equal(draws[k], np.random.default_rng(child).random(5))
    assert not np.array_equal(draws[0], draws[1])
