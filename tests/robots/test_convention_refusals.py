"""A joint convention that cannot be inverted or is no convention is refused, saying why.

The convention is lower-triangular (a joint tied to earlier joints only), so
it inverts by forward substitution: a joint tied to itself or to a later
joint would make ``to_controller`` silently wrong.
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator.robots import DescriptionError, JointConvention


@pytest.mark.parametrize("sign", [(2.0,) + (1.0,) * 5, (1.0,) * 5, (0.0,) + (1.0,) * 5])
def test_a_sign_other_than_six_plus_or_minus_ones_is_refused(sign):
    with pytest.raises(DescriptionError) as refused:
        JointConvention(sign=sign)
    assert str(refused.value) == "joint convention: sign must be six values of +1 or -1"


@pytest.mark.parametrize("offset", [(0.0,) * 5, (0.0,) * 5 + (np.nan,)])
def test_an_offset_other_than_six_finite_angles_is_refused(offset):
    with pytest.raises(DescriptionError, match="offset_rad must be six finite angles"):
        JointConvention(offset_rad=offset)


@pytest.mark.parametrize(
    "coupling", [(2, 2, 1.0), (1, 2, 1.0), (6, 1, 1.0), (2, -1, 1.0), (2, 1, np.inf)]
)
def test_a_coupling_to_itself_a_later_joint_or_no_joint_is_refused(coupling):
    with pytest.raises(DescriptionError) as refused:
        JointConvention(couplings=(coupling,))
    assert str(refused.value).startswith(f"joint convention: coupling {coupling} must tie")


def test_a_coupling_to_an_earlier_joint_inverts():
    conv = JointConvention(couplings=((5, 0, 0.5), (1, 0, -1.0)))
    q = np.array([[0.3, -0.2, 0.1, 0.0, 0.4, -0.7]])
    np.testing.assert_allclose(conv.to_controller(conv.to_model(q)), q, atol=1e-15)
