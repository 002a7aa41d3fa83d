"""Plan files (calibrator/planning/planfile.py): read exactly or refused, written to read back.

No column or value silently dropped; the via rows and the origin columns round-trip.
"""

import numpy as np
import pytest

from calibrator import planning, robots
from calibrator.model import frames
from calibrator.planning import PlanError

UR10E = robots.get("ur10e")
TOOL = frames.transform(translation=[0.0, 0.0, 100.0])
TOOL_MM = (0.0, 0.0, 100.0)
LIMITS = np.tile([-2.0, 3.0], (6, 1))


HEADER = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"


def _refusal(tmp_path, text):
    path = tmp_path / "plan.csv"
    path.write_text(text)
    with pytest.raises(PlanError) as info:
        planning.read_csv(path)
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
    np.testing.assert_array_equal(planning.read_csv(path), q)


def test_a_written_plan_reads_back_exactly(tmp_path):
    q = np.random.default_rng(3).uniform(-3, 3, (7, 6))
    planning.write_plan(tmp_path / "p.csv", planning.Plan(q))
    lines = (tmp_path / "p.csv").read_text().split("\n")
    assert lines[0] == "pose,via,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"
    assert [line.split(",")[:2] for line in lines[1:-1]] == [[str(i), "0"] for i in range(7)]
    assert lines[-1] == ""
    np.testing.assert_array_equal(planning.read_csv(tmp_path / "p.csv"), q)


def test_a_plan_in_degrees_is_read_in_radians(tmp_path):
    (tmp_path / "d.csv").write_text(
        "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n180,90,-45,0,30,360\n"
    )
    np.testing.assert_allclose(
        planning.read_csv(tmp_path / "d.csv"),
        [[np.pi, np.pi / 2, -np.pi / 4, 0, np.pi / 6, 2 * np.pi]],
        rtol=1e-15,
    )
    both = "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n"
    (tmp_path / "b.csv").write_text(both + "1,1,1,1,1,1,9,9,9,9,9,9\n")
    with pytest.raises(planning.PlanError, match="both q1_rad..q6_rad and q1_deg..q6_deg"):
        planning.read_csv(tmp_path / "b.csv")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (None, "^cannot read plan .*p.csv: "),
        (b"\xff\xfe\x00", "^cannot read plan "),
        ("q1_rad,q2_rad,q3_rad,q4_rad,q5_rad\n1,2,3,4,5\n", "needs columns q1_rad,q2_rad,"),
        ("", "needs columns q1_rad,.*,q6_rad \\(or q1_deg..q6_deg\\)$"),
        ("q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n", ": the plan has no poses$"),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n1,2,3,4,5,x\n",
            "line 2, q6_rad: 'x' is not a decimal number$",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n1,2,3,4,5\n",
            "line 2, q6_rad: '' is not a decimal number$",
        ),
        (
            "q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n1,2,3,4,5,nan\n",
            "line 2, q6_rad: 'nan' is not a decimal",
        ),
        (
            "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg\n1,2,3,4,5,-inf\n",
            "line 2, q6_deg: '-inf' is not a decimal",
        ),
    ],
)
def test_a_bad_plan_file_is_refused_naming_the_problem(tmp_path, text, message):
    path = tmp_path / "p.csv"
    if isinstance(text, bytes):
        path.write_bytes(text)
    elif text is not None:
        path.write_text(text)
    with pytest.raises(planning.PlanError, match=message):
        planning.read_csv(path)


def test_plan_files_round_trip_with_vias(tmp_path):
    q = np.arange(18, dtype=float).reshape(3, 6) / 10
    via = (np.zeros((0, 6)), np.full((2, 6), 0.5), np.zeros((0, 6)))
    plan = planning.Plan(q, via)
    planning.write_plan(tmp_path / "p.csv", plan)
    text = (tmp_path / "p.csv").read_text()
    assert text.splitlines()[0] == "pose,via,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"
    assert [line.split(",")[:2] for line in text.splitlines()[1:]] == [
        ["0", "0"], ["", "1"], ["", "1"], ["1", "0"], ["2", "0"]
    ]  # fmt: skip
    back = planning.read_plan(tmp_path / "p.csv")
    np.testing.assert_array_equal(back.q_rad, q)
    assert [v.shape[0] for v in back.via_rad] == [0, 2, 0]
    np.testing.assert_array_equal(back.path_rad, plan.path_rad)
    # The plain reader refuses to measure via rows as poses.
    with pytest.raises(planning.PlanError, match="has via rows"):
        planning.read_csv(tmp_path / "p.csv")
    # Without vias, both readers agree.
    planning.write_plan(tmp_path / "plain.csv", planning.Plan(q))
    np.testing.assert_array_equal(planning.read_csv(tmp_path / "plain.csv"), q)
    np.testing.assert_array_equal(planning.read_plan(tmp_path / "plain.csv").q_rad, q)


@pytest.mark.parametrize(
    ("rows", "message"),
    [
        ("0,2,0,0,0,0,0,0\n", "via must be 0 or 1"),
        ("0,0,0,0,0,0,0,0\n,1,0,0,0,0,0,0\n", "via rows after the last measured pose"),
    ],
)
def test_bad_via_rows_are_refused(tmp_path, rows, message):
    path = tmp_path / "p.csv"
    path.write_text("pose,via,q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n" + rows)
    with pytest.raises(planning.PlanError, match=message):
        planning.read_plan(path)
