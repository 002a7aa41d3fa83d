"""Kinematics and geometry against references built by a different route.

The identify tests make their data with the same ``forward`` they fit with,
so a bug in the chain cancels out there. These tests compare with a chain
written out link by link from ``scipy.spatial.transform.Rotation``, on tables
where every link has alpha != 0 and beta != 0 (so Rx.Ry cannot pass for Ry.Rx).
"""

import numpy as np
from reference_kit import homogeneous as _h
from scipy.spatial.transform import Rotation

from calibrator.halton import halton
from calibrator.model import frames, kinematics


def reference_chain(mdh, q):
    """``prod_i Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i) Ry(beta_i)``, one 4x4 at a time."""
    t = np.eye(4)
    for (a, alpha, theta, d, beta), qi in zip(mdh, q, strict=True):
        t = (
            t
            @ _h(Rotation.from_euler("z", theta + qi))
            @ _h(translation=(0.0, 0.0, d))
            @ _h(translation=(a, 0.0, 0.0))
            @ _h(Rotation.from_euler("x", alpha))
            @ _h(Rotation.from_euler("y", beta))
        )
    return t


def random_table(rng):
    """MDH table with every entry non-zero: alpha and beta both turn every link."""
    a = rng.uniform(50, 800, 6) * rng.choice([-1, 1], 6)
    d = rng.uniform(50, 800, 6) * rng.choice([-1, 1], 6)
    alpha = rng.uniform(0.2, 1.4, 6) * rng.choice([-1, 1], 6)
    beta = rng.uniform(0.1, 0.6, 6) * rng.choice([-1, 1], 6)
    theta = rng.uniform(-np.pi, np.pi, 6)
    return np.column_stack([a, alpha, theta, d, beta])


def random_transform(rng, scale_mm):
    return _h(Rotation.random(random_state=rng), rng.normal(0, scale_mm, 3))


def test_forward_equals_a_chain_written_out_with_scipy_rotations():
    rng = np.random.default_rng(14)
    mdh = random_table(rng)
    assert np.all(np.abs(mdh[:, kinematics.ALPHA]) > 0.1)
    assert np.all(np.abs(mdh[:, kinematics.BETA]) > 0.05)
    q = rng.uniform(-np.pi, np.pi, (9, 6))
    base2tracker = random_transform(rng, 2000.0)
    flange2tool = random_transform(rng, 100.0)
    ours = kinematics.forward(mdh, q, flange2tool, base2tracker)
    theirs = np.array([base2tracker @ reference_chain(mdh, qq) @ flange2tool for qq in q])
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-9)
    # Without frames the result is the bare chain, base frame to flange.
    bare = kinematics.forward(mdh, q)
    np.testing.assert_allclose(bare, [reference_chain(mdh, qq) for qq in q], atol=1e-9)


def test_every_intermediate_frame_matches_the_reference():
    rng = np.random.default_rng(15)
    mdh = random_table(rng)
    q = rng.uniform(-np.pi, np.pi, (4, 6))
    _, link = kinematics.chain(mdh, q, all_frames=True)
    for i in range(7):
        expected = [reference_chain(mdh[:i], qq[:i]) for qq in q]
        np.testing.assert_allclose(link[:, i], expected, atol=1e-9)


def test_a_swarm_of_tables_matches_the_reference_per_table():
    rng = np.random.default_rng(16)
    tables = np.stack([random_table(rng) for _ in range(3)])
    q = rng.uniform(-np.pi, np.pi, (5, 6))
    out = kinematics.forward(tables, q)
    for p, mdh in enumerate(tables):
        np.testing.assert_allclose(out[p], [reference_chain(mdh, qq) for qq in q], atol=1e-9)


def test_rigid_fit_of_mirrored_points_is_still_a_proper_rotation():
    # Target is a mirror image of the source: the best orthogonal map is a
    # reflection, which the Kabsch sign fix must turn into the best rotation.
    rng = np.random.default_rng(3)
    source = rng.normal(0, 300, (10, 3))
    target = source * np.array([1.0, 1.0, -1.0]) + [500.0, 0, 0]
    fit = frames.fit_rigid(source, target)
    r = fit[:3, :3]
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) > 0.999

    # And it is the best rotation: no random rotation does better.
    def sse(t):
        return np.sum((source @ t[:3, :3].T + t[:3, 3] - target) ** 2)

    best = sse(fit)
    for rot in Rotation.random(200, random_state=4).as_matrix():
        t = frames.transform(rot, target.mean(0) - rot @ source.mean(0))
        assert sse(t) >= best - 1e-6


def test_halton_scrambles_each_digit_position_with_its_own_permutation():
    # Point 0 has every digit 0: with one permutation per base it maps to
    # pi(0) * (1/b + 1/b^2 + ...) = pi(0) / (b - 1), so in base 2 only 0 or 1;
    # with a permutation per digit position it is a uniform random number.
    first = np.array([halton(1, 2, np.random.default_rng(s))[0] for s in range(40)])
    assert len(np.unique(np.round(first[:, 0], 9))) > 10
    assert 0.2 < first[:, 0].mean() < 0.8
    # base 3: one permutation per base would give only 0, 1/2 or ~1.
    assert len(np.unique(np.round(first[:, 1], 9))) > 10
