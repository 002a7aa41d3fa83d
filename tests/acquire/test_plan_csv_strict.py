"""A plan CSV is read exactly or refused: no column or value silently dropped."""

import numpy as np
import pytest

from calibrator import plan
from calibrator.plan import PlanError

HEADER = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"


def _refusal(tmp_path, text):
    path = tmp_path / "plan.csv"
    path.write_text(text)
    with pytest.raises(PlanError) as info:
        plan.read_csv(path)
    return str(info.value).removeprefix(f"{path}: ")


def test_a_repeated_column_is_refused_not_read_from_its_last_copy(tmp_path):
    text = f"{HEADER},q2_rad\n0.1,0.2,0.3,0.4,0.5,0.6,9.9\n"
    assert _refusal(tmp_path, text) == "repeated column(s) q2_rad"


def test_radians_and_degrees_together_are_ambiguous(tmp_path):
    deg = ",".join(f"q{i}_deg" for i in range(1, 7))
    text = f"{HEADER},{deg}\n" + ",".join(["0.1"] * 6 + ["5.7"] * 6) + "\n"
    assert _refusal(tmp_path, text) == "both q1_rad..q6_rad and q1_deg..q6_deg; keep one set"


def test_a_row_longer_than_the_header_is_refused(tmp_path):
    text = f"{HEADER}\n0.1,0.2,0.3,0.4,0.5,0.6\n0.1,0.2,0.3,0.4,0.5,0.6,0.7\n"
    assert _refusal(tmp_path, text) == "a row has more values than the header"


def test_a_well_formed_plan_reads_exactly(tmp_path):
    path = tmp_path / "plan.csv"
    q = np.array([[0.1, -0.2, 0.3, -0.4, 0.5, -0.6], [1.0, 1.1, 1.2, 1.3, 1.4, 1.5]])
    rows = "".join(f"{i}," + ",".join(repr(float(v)) for v in r) + "\n" for i, r in enumerate(q))
    path.write_text(f"pose,{HEADER}\n{rows}")
    np.testing.assert_array_equal(plan.read_csv(path), q)
