"""A description file over a URDF states the margin its capsules hold, given or not.

Without ``margin_mm`` the URDF's capsules get the fit's default margin
(10 mm): a file giving ``link_radius_mm`` but no margin was refused as if
its kinematics were no URDF's, and one giving neither stated 0 mm for
capsules 10 mm wider than the links.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from robot_files_kit import DATA

from calibrator import robots
from calibrator.robots import urdf

HEAD = """\
format: calibrator-robot/1
name: margin-arm
source: the shipped KR 6 URDF
kinematics:
  urdf: arm.urdf
body:
"""
RADII = [100, 80, 70, 60, 50, 40]


def _read(tmp_path, body):
    shutil.copy(DATA / "kuka-kr6-r900.urdf", tmp_path / "arm.urdf")
    (tmp_path / "arm.yaml").write_text(HEAD + body)
    return robots.get(str(tmp_path / "arm.yaml"))


@pytest.mark.parametrize(
    ("body", "margin"),
    [
        (f"  link_radius_mm: {RADII}\n", urdf.FIT_MARGIN_MM),
        (f"  margin_mm: 0\n  link_radius_mm: {RADII}\n", 0.0),
        (f"  margin_mm: 4\n  link_radius_mm: {RADII}\n", 4.0),
    ],
)
def test_link_radii_get_the_stated_margin_or_the_fits(tmp_path, body, margin):
    arm = _read(tmp_path, body)
    assert arm.body.margin_mm == margin
    radius = {c.link: c.radius_mm for c in arm.body.capsules}
    np.testing.assert_allclose([radius[k] for k in range(1, 7)], np.add(RADII, margin))


def test_a_body_of_base_radii_only_states_the_margin_of_the_urdfs_capsules(tmp_path):
    arm = _read(tmp_path, "  base_radius_mm: 170\n")
    alone = urdf.describe(tmp_path / "arm.urdf")
    assert arm.body.base_radius_mm == 170.0
    assert arm.body.capsules == alone.body.capsules
    assert arm.body.margin_mm == alone.body.margin_mm == urdf.FIT_MARGIN_MM
