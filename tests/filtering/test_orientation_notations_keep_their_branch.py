"""Each language's orientation notation, written back on the branch the program used.

A rotation has two sets of Z-Y-X angles (KRL's A B C, Fanuc's W P R,
Yaskawa's Rx Ry Rz) and each angle is only defined modulo 360 deg; a unit
quaternion (RAPID) has two signs. A target taught at exactly +-180 deg (the
turn boundary, where a pendant may show either) and corrected by a small
rotation must come back within that correction of the program's numbers:
never as the other branch or 360 deg away, which a controller interpolating
orientation would turn the long way. Hypothesis draws the program's values
(on the boundaries and anywhere) and the corrections.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from calibrator.languages.fanuc import reader as fanuc
from calibrator.languages.jbi import reader as jbi
from calibrator.languages.krl import reader as krl
from calibrator.languages.rapid import reader as rapid
from calibrator.model import rotations

SETTINGS = settings(max_examples=60, deadline=None, derandomize=True)
#: Where the three angles sit in each language's six numbers (Z, Y, X order).
ZYX_COLUMNS = {"krl": (krl, [3, 4, 5]), "fanuc": (fanuc, [5, 4, 3]), "jbi": (jbi, [5, 4, 3])}

_z_or_x = st.one_of(
    st.sampled_from([-180.0, 180.0, 0.0, -90.0, 90.0, 179.99, -179.99]),
    st.floats(-180.0, 180.0),
)
_y = st.one_of(st.sampled_from([0.0, -45.0, 60.0]), st.floats(-80.0, 80.0))
_turn = st.lists(st.floats(-0.005, 0.005), min_size=3, max_size=3)


@pytest.mark.parametrize("lang", sorted(ZYX_COLUMNS))
@SETTINGS
@given(z=_z_or_x, y=_y, x=_z_or_x, turn=_turn)
def test_zyx_angles_stay_on_the_programs_branch(lang, z, y, x, turn):
    module, cols = ZYX_COLUMNS[lang]
    old = np.zeros((1, 6))
    old[0, :3] = [250.0, -40.0, 900.0]
    old[0, cols] = [z, y, x]
    pose = module._decode_pose(old)
    pose[0, :3, :3] = rotations.rotvec_to_matrix(np.array(turn)) @ pose[0, :3, :3]
    pose[0, :3, 3] += [0.3, -0.2, 0.1]
    new = module._encode_pose(pose, old)
    np.testing.assert_allclose(new[0, :3], [250.3, -40.2, 900.1], atol=1e-9)
    # Each angle within the correction (0.005 rad is 0.29 deg; A and C move up to a few
    # times that at B = 80 deg) of the program's: no other branch, no 360 deg jump.
    assert np.abs(new[0, cols] - old[0, cols]).max() < 2.0, (old, new)
    np.testing.assert_allclose(module._decode_pose(new), pose, atol=1e-9)


@SETTINGS
@given(
    axis=st.tuples(*[st.floats(-1.0, 1.0)] * 3).filter(lambda a: np.linalg.norm(a) > 0.1),
    angle=st.one_of(st.sampled_from([0.0, np.pi, -np.pi]), st.floats(-np.pi, np.pi)),
    sign=st.sampled_from([1.0, -1.0]),
    turn=_turn,
)
def test_a_rapid_quaternion_keeps_the_programs_sign(axis, angle, sign, turn):
    """``[w, x, y, z]`` and its negative are one rotation: the written one is the program's."""
    a = np.asarray(axis) / np.linalg.norm(axis)
    q_old = sign * np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * a])
    old = np.concatenate([[100.0, 200.0, 300.0], q_old])[None]
    pose = rapid._decode_pose(old)
    pose[0, :3, :3] = rotations.rotvec_to_matrix(np.array(turn)) @ pose[0, :3, :3]
    new = rapid._encode_pose(pose, old)
    assert np.abs(new[0, 3:] - q_old).max() < 0.01, (q_old, new)
    np.testing.assert_allclose(np.linalg.norm(new[0, 3:]), 1.0, atol=1e-12)
    np.testing.assert_allclose(rapid._decode_pose(new), pose, atol=1e-9)
