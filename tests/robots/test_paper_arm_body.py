"""The IPSO paper's arm (er10l-c10): a body along its MDH links, standing where it says.

The paper gives no link dimensions: the module draws the capsules along the
MDH segments (each link ``i`` from joint ``i``'s axis, ``(-a_i, 0, 0)`` in
frame ``i``, to its origin, then along ``z_i`` for ``d_{i+1}``), puts the
base 450 mm below the shoulder and holds the arm straight up as ``upright``.
Simulated runs of this arm plan their poses against that body.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator import robots
from calibrator.model import distance, kinematics
from calibrator.robots import ipso_paper


@pytest.fixture
def arm():
    """The arm as its module builds it (``robots.get`` builds it once per process)."""
    built = ipso_paper.DESCRIPTIONS[ipso_paper.NAME]()
    assert built.digest == robots.get("er10l-c10").digest
    return built


def _skeleton(mdh, link):
    """Link ``link``'s MDH segments in its own frame (mm): [(start, end), ...]."""
    out = [((-mdh[link - 1, kinematics.A], 0.0, 0.0), (0.0, 0.0, 0.0))]
    if link < 6:
        out.append(((0.0, 0.0, 0.0), (0.0, 0.0, mdh[link, kinematics.D])))
    return [(np.array(a, float), np.array(b, float)) for a, b in out]


def _to_segment_mm(point, segment):
    return float(distance.segment_segment(point, point, *segment))


def test_every_capsule_lies_along_its_own_links_segments(arm):
    for capsule in arm.body.capsules:
        segments = _skeleton(arm.mdh, capsule.link)
        for end in (capsule.p_mm, capsule.q_mm):
            gap = min(_to_segment_mm(np.array(end), s) for s in segments)
            # On the segment's line, and past its ends by no more than the radius.
            assert gap <= capsule.radius_mm, (capsule.name, end, gap)


def test_the_capsules_enclose_every_links_segments_in_any_pose(arm):
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (12, 6))
    frames = kinematics.chain(arm.mdh, q, all_frames=True)[1]  # (12, 7, 4, 4), frame 0 first
    t = np.linspace(0.0, 1.0, 11)
    for pose in range(len(q)):
        capsules = [
            (
                (frames[pose, c.link] @ np.append(c.p_mm, 1.0))[:3],
                (frames[pose, c.link] @ np.append(c.q_mm, 1.0))[:3],
                c.radius_mm,
            )
            for c in arm.body.capsules
        ]
        for link in range(1, 7):
            for a, b in _skeleton(arm.mdh, link):
                for point in a + t[:, None] * (b - a):
                    at = (frames[pose, link] @ np.append(point, 1.0))[:3]
                    assert any(_to_segment_mm(at, (p, e)) <= r + 1e-9 for p, e, r in capsules), (
                        pose,
                        link,
                        point,
                    )


def test_the_base_stands_450_mm_below_the_shoulder_and_says_its_radii_are_guessed(arm):
    body = arm.body
    assert body.mount_z_mm == -450.0
    assert body.mount_z_mm < body.base_top_mm < 0.0 == body.shoulder_mm[2]
    assert "the paper gives no link dimensions" in body.source


def test_upright_holds_the_upper_arm_and_the_forearms_axis_straight_up(arm):
    up = np.array(arm.configuration("upright"))
    assert arm.upright_rad == (up[1], up[2])
    frames = kinematics.chain(arm.mdh, up[None], all_frames=True)[1][0]
    upper_arm = frames[2, :3, 3] - frames[1, :3, 3]
    np.testing.assert_allclose(upper_arm, [0.0, 0.0, arm.mdh[1, kinematics.A]], atol=1e-9)
    np.testing.assert_allclose(frames[3, :3, 2], [0.0, 0.0, 1.0], atol=1e-12)  # joint 4's axis
    # The wrist centre right above the elbow, the forearm's length higher.
    np.testing.assert_allclose(
        frames[4, :3, 3] - frames[3, :3, 3], [0.0, 0.0, arm.mdh[3, kinematics.D]], atol=1e-9
    )
