"""Options that allocate, wait or compute far away: refused above their bound before any work."""

import json
import re

import pytest
from cli_kit import cli, listing, one_line_error


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (
            ["verify", "--cycles", "1000000000"],
            "--cycles: 1000000000 cycles is more than the limit",
        ),
        (["verify", "--cycles", "999999999999"], "--cycles: 999999999999 cycles is more than"),
        (
            ["verify", "--cube", "976,0,621,1e308"],
            "--cube: '976,0,621,1e308' is beyond +-100000 mm",
        ),
        (["verify", "--cube", "976,0,621,1e-300"], "--cube: an edge of 1e-300 mm is below 10 mm"),
        (["analyze", "deflection", "--samples", "1000000000"], "--samples: 1000000000 samples"),
        (["analyze", "deflection", "--pose", "1e308,0,0,0,0"], "--pose: joint 1 at 1e+308 deg"),
        (["analyze", "deflection", "--pose", "400,0,0,0,0"], "beyond its limits [-180, 180] deg"),
        (["analyze", "deflection", "--start", "0,0,-5,0,0"], "joint 3 at -5 mm is beyond"),
        (["analyze", "deflection", "--duration", "1e-300"], "--duration: must be a number >= 0.01"),
        (["analyze", "deflection", "--duration", "1e9"], "--duration: 1e+09 s is more than"),
        (["analyze", "deflection", "--ramp", "5e-324"], "--ramp: must be a number >= 0.01"),
    ],
)
def test_an_option_beyond_its_bound_is_one_line(tmp_path, args, says):
    extra = ["--robot", "sim", "--tracker", "sim", "--yes"] if args[0] == "verify" else []
    result = cli(*args, *extra, cwd=tmp_path)
    line = one_line_error(result)  # one line: no numpy overflow warning before it
    assert says in line, line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("links", "says"),
    [
        ("{outer_mm: 1e-300}", "link 2: outer_mm: must be a number >= 1, got 1e-300"),
        ("{outer_mm: 1e308}", "link 2: outer_mm: 1e+308 mm is more than the limit of 2000 mm"),
        ("{outer_mm: 120, e_mpa: 1e-300}", "e_mpa: must be a number >= 100"),
        ("{outer_mm: true}", "outer_mm: must be a number, got True"),
        ("{outer_mm: '120'}", "outer_mm: must be a number, got '120'"),
    ],
)
def test_a_section_outside_a_robot_link_is_refused(tmp_path, links, says):
    (tmp_path / "s.yaml").write_text(f"links:\n  2: {links}\n")
    before = listing(tmp_path)
    line = one_line_error(
        cli("analyze", "deflection", "--model", "ur10e", "--sections", "s.yaml", cwd=tmp_path)
    )
    assert line.startswith("calibrator: error: s.yaml: ") and says in line, line
    assert listing(tmp_path) == before


def test_a_pose_within_the_named_models_limits_runs(tmp_path):
    (tmp_path / "s.yaml").write_text("links:\n  2: {outer_mm: 120, inner_mm: 100}\n")
    args = ["analyze", "deflection", "--model", "ur10e", "--sections", "s.yaml"]
    done = cli(*args, "--pose", "0,-90,90,0,0,0", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "nan" not in done.stdout
    line = one_line_error(cli(*args, "--pose", "0,-90,400,0,0,0", cwd=tmp_path))
    assert "--pose: joint 3 at 400 deg is beyond its limits [-180, 180] deg" in line


def test_a_model_name_compares_case_insensitively(tmp_path):
    done = cli("simulate", "--model", "ur10e", "--poses", "30", "-o", "s.parquet", cwd=tmp_path)
    assert done.code == 0, done.stderr
    done = cli("identify", "s.parquet", "--method", "lm", "-o", "cal.json", "-q", cwd=tmp_path)
    assert done.code == 0, done.stderr
    doc = json.loads((tmp_path / "cal.json").read_text())
    doc["model"] = "UR10E"
    (tmp_path / "upper.json").write_text(json.dumps(doc))
    before = listing(tmp_path)
    # A cube out of reach stops verify after the model check, before any device opens.
    line = one_line_error(
        cli("verify", "--robot", "sim", "--tracker", "sim", "--model", "ur10e", "--calibration",
            "upper.json", "--cube", "976,0,621,5000", "--yes", cwd=tmp_path)
    )  # fmt: skip
    assert "calibrates a" not in line and "out of reach" in line, line
    assert listing(tmp_path) == before


def test_a_candidate_file_meets_the_candidates_budget(tmp_path):
    rows = "0.1,-1.2,1.3,-1.4,1.5,0.6\n" * 200_001
    (tmp_path / "c.csv").write_text("q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad\n" + rows)
    before = listing(tmp_path)
    line = one_line_error(cli("plan", "--from", "c.csv", "-o", "p.csv", cwd=tmp_path))
    assert "--from c.csv: more than 200000 rows of candidates" in line
    assert listing(tmp_path) == before


def test_a_cell_file_meets_the_obstacle_budget(tmp_path):
    box = "  - box: {min_mm: [3000, 0, 0], max_mm: [3005, 5, 5]}\n"
    (tmp_path / "cell.yaml").write_text("obstacles:\n" + box * 101)
    line = one_line_error(cli("plan", "--cell", "cell.yaml", "-o", "p.csv", cwd=tmp_path))
    assert "cell.yaml: obstacles: 101 is more than the limit of 100" in line


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["--target-mm", "1e-300"], "--target-mm: must be a number >= 0.0001, got 1e-300"),
        (["--target-mm", "1e300"], "--target-mm: 1e+300 mm is more than the limit of 10000 mm"),
        (["--noise-mm", "1e-300"], "--noise-mm: must be a number >= 1e-09, got 1e-300"),
    ],
)
def test_identify_report_options_are_bounded(tmp_path, args, says):
    done = cli("simulate", "--model", "ur10e", "--poses", "30", "-o", "s.parquet", cwd=tmp_path)
    assert done.code == 0, done.stderr
    before = listing(tmp_path)
    line = one_line_error(cli("identify", "s.parquet", "-o", "c.json", *args, cwd=tmp_path))
    assert says in line
    assert listing(tmp_path) == before  # refused before anything is written


def test_a_recorded_joint_term_payload_meets_the_payload_rules(tmp_path):
    from calibrator.errors import CalibrationError
    from calibrator.model.joint_terms import JointTerms

    for comp, says in [
        ({"payload_kg": 1e308}, "payload_kg: 1e+308 kg is more than the limit of 100 kg"),
        ({"payload_kg": -5}, "payload_kg: must be a number >= 0, got -5"),
        ({"payload_kg": "5"}, "payload_kg: must be a number, got '5'"),
        ({"payload_com_mm": [1e308, 0, 0]}, "payload_com_mm: 1e+308 mm is beyond +-2000 mm"),
        ({"mass_model": ["x"] * 3}, "mass_model must be text"),
    ]:
        with pytest.raises(CalibrationError, match=re.escape(says)):
            JointTerms.from_json({"compliance": comp})
    line = one_line_error(
        cli("compensate", "c.json", "t.csv", "-o", "o.csv", "--payload-kg", "1e308", cwd=tmp_path)
    )
    assert "--payload-kg: 1e+308 kg is more than the limit of 100 kg" in line


@pytest.mark.parametrize(
    ("link", "says"),
    [
        ("{mass_kg: 1e308, com_mm: [0, 0, 0]}", "link 1 mass_kg: 1e+308 kg is more than the limit"),
        ("{mass_kg: '5', com_mm: [0, 0, 0]}", "link 1 mass_kg: must be a number, got '5'"),
        ("{mass_kg: 5, com_mm: [0, 0, 1e308]}", "link 1 com_mm: 1e+308 mm is beyond +-5000 mm"),
        ("{mass_kg: 5, com_mm: [0, 0, 0], extra: 1}", "link 1 needs exactly mass_kg"),
    ],
)
def test_a_mass_model_file_holds_robot_links(tmp_path, link, says):
    (tmp_path / "s.yaml").write_text("links:\n  2: {outer_mm: 120, inner_mm: 100}\n")
    (tmp_path / "m.yaml").write_text("links:\n" + f"  - {link}\n" * 6)
    line = one_line_error(
        cli("analyze", "deflection", "--model", "ur10e", "--sections", "s.yaml", "--masses",
            "m.yaml", cwd=tmp_path)
    )  # fmt: skip
    assert "m.yaml: " in line and says in line, line


@pytest.mark.parametrize(
    ("where", "value", "says"),
    [
        ("footer", 1e308, "the session's payload_kg: 1e+308 kg is more than the limit of 100 kg"),
        ("footer", "5", "the session's payload_kg: must be a number, got '5'"),
        ("column", 1e6, "the session's payload_kg column: 1e+06 kg is more than the limit"),
        ("column", -1.0, "the session's payload_kg column: must be a number >= 0, got -1"),
    ],
)
def test_a_sessions_recorded_payload_meets_the_payload_rule(tmp_path, where, value, says):
    import pyarrow as pa
    import pyarrow.parquet as pq

    done = cli("simulate", "--model", "ur10e", "--poses", "30", "-o", "s.parquet", cwd=tmp_path)
    assert done.code == 0, done.stderr
    table = pq.read_table(tmp_path / "s.parquet")
    meta = dict(table.schema.metadata)
    if where == "footer":
        doc = json.loads(meta[b"calibrator"])
        doc["payload_kg"] = value
        meta[b"calibrator"] = json.dumps(doc).encode()
    else:
        table = table.append_column("payload_kg", pa.array([value] * table.num_rows))
    pq.write_table(table.replace_schema_metadata(meta), tmp_path / "p.parquet")
    before = listing(tmp_path)
    line = one_line_error(
        cli("identify", "p.parquet", "--joint-terms", "scale", "-o", "c.json", "-q",
            "--method", "lm", cwd=tmp_path)
    )  # fmt: skip
    assert says in line, line
    assert listing(tmp_path) == before


def test_a_section_keyed_true_is_not_link_1(tmp_path):
    (tmp_path / "s.yaml").write_text("links:\n  true: {outer_mm: 120, inner_mm: 100}\n")
    line = one_line_error(
        cli("analyze", "deflection", "--model", "ur10e", "--sections", "s.yaml", cwd=tmp_path)
    )
    assert "s.yaml: link True: keys are link numbers 1..6" in line
