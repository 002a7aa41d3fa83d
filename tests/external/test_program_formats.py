"""``calibrator program``: every format parses under its grammar and round-trips the plan."""

import csv
import io
import re

import numpy as np
import pytest
from cli_kit import cli, one_line_error
from grammar_kit import PARSERS, GrammarError, parse_krl, parse_rapid, parse_urscript

from calibrator import planning, robots
from calibrator.languages import writing as programs
from calibrator.languages.spec import move_duration_s

ARM = robots.get("ur10e")


def _plan(n=25, seed=4):
    """Joint angles with every digit used and values near the limits (rad)."""
    rng = np.random.default_rng(seed)
    lo, hi = ARM.joint_limits_rad[:, 0], ARM.joint_limits_rad[:, 1]
    q = rng.uniform(lo * 0.98, hi * 0.98, size=(n, 6))
    q[0] = hi * 0.999  # as far out as a plan goes
    return q


def _spec(q, **kw):
    args = dict(
        plan_rad=q,
        home_rad=np.zeros(6) + 0.123456789,
        speed_rad_s=ARM.move_speed_cap_rad_s,
        accel_rad_s2=ARM.move_accel_cap_rad_s2,
        max_joint_speed_rad_s=ARM.max_joint_speed_rad_s,
        dwell_s=1.75,
        pulse_output=2,
        name="cal_run",
        model=ARM.name,
    )
    args.update(kw)
    return programs.ProgramSpec(**args)


@pytest.mark.parametrize("fmt", ["urscript", "krl", "rapid", "fanuc-ls"])
def test_every_statement_parses_and_joints_round_trip_within_1e_6_rad(fmt):
    q = _plan()
    spec = _spec(q)
    parsed = PARSERS[fmt](programs.render(spec, fmt))
    targets = np.array(parsed.targets())
    # home, one motion statement per pose in plan order, home
    assert len(targets) == len(q) + 2
    np.testing.assert_allclose(targets[1:-1], q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(targets[[0, -1]], [spec.home_rad] * 2, rtol=0, atol=1e-6)
    # a dwell per pose as long as asked (pulse time included), a pulse per pose
    assert parsed.pulses == len(q)
    assert sum(parsed.waits) == pytest.approx(len(q) * spec.dwell_s, abs=1e-6)


@pytest.mark.parametrize("fmt", ["urscript", "krl", "rapid"])
def test_one_literal_motion_statement_per_pose(fmt):
    q = _plan(12, seed=9)
    parsed = PARSERS[fmt](programs.render(_spec(q), fmt))
    literal = np.array(parsed.literal())
    assert literal.shape == (12, 6)  # home moves name their target, poses are literal
    np.testing.assert_allclose(literal, q, rtol=0, atol=1e-6)


def test_speeds_never_exceed_the_model_ceiling():
    q = _plan()
    ur = parse_urscript(programs.render(_spec(q), "urscript"))
    assert ur.speeds["v"] == {ARM.move_speed_cap_rad_s}
    assert ur.speeds["a"] == {ARM.move_accel_cap_rad_s2}
    krl = parse_krl(programs.render(_spec(q), "krl"))
    joint_speed = np.array([krl.speeds[i] for i in range(1, 7)]) / 100 * ARM.max_joint_speed_rad_s
    assert np.all(joint_speed <= ARM.move_speed_cap_rad_s + 1e-12)
    assert np.all(joint_speed > 0.9 * ARM.move_speed_cap_rad_s)  # not needlessly slow
    rapid = parse_rapid(programs.render(_spec(q), "rapid"))
    assert rapid.move_times[0] is None  # first move from an unknown place: not timed
    targets = np.array(rapid.targets())
    for k in range(1, len(targets)):
        need = move_duration_s(targets[k - 1], targets[k], ARM.move_speed_cap_rad_s, 2.0)
        assert rapid.move_times[k] >= need - 1e-9


def test_a_slower_speed_is_written_as_asked():
    parsed = parse_urscript(programs.render(_spec(_plan(), speed_rad_s=0.25), "urscript"))
    assert parsed.speeds["v"] == {0.25}


def test_without_a_pulse_no_output_is_touched():
    for fmt, parse in PARSERS.items():
        parsed = parse(programs.render(_spec(_plan(5), pulse_output=None), fmt))
        assert parsed.pulses == 0, fmt


def test_the_checkers_refuse_a_broken_statement():
    text = programs.render(_spec(_plan(5)), "rapid").replace("fine, tool0;", "fine tool0;", 1)
    with pytest.raises(GrammarError):
        parse_rapid(text)
    text = programs.render(_spec(_plan(5)), "krl").replace("WAIT SEC", "WAIT", 1)
    with pytest.raises(GrammarError):
        parse_krl(text)


def test_csv_rows_round_trip(tmp_path):
    q = _plan(8)
    text = programs.render(_spec(q), "csv")
    rows = list(csv.DictReader(io.StringIO(text)))
    assert [r["kind"] for r in rows] == ["home"] + ["pose"] * 8 + ["home"]
    poses = [r for r in rows if r["kind"] == "pose"]
    assert [int(r["pose"]) for r in poses] == list(range(8))
    rad = np.array([[float(r[f"q{i}_rad"]) for i in range(1, 7)] for r in poses])
    deg = np.array([[float(r[f"q{i}_deg"]) for i in range(1, 7)] for r in poses])
    np.testing.assert_allclose(rad, q, rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.radians(deg), q, rtol=0, atol=1e-6)


# ---------------------------------------------------------------- command line


@pytest.fixture
def plan_csv(tmp_path, checked_plan):
    """A plan the whole-plan check passes (program refuses any other)."""
    path = tmp_path / "plan.csv"
    planning.write_plan(path, checked_plan)
    return path


@pytest.mark.parametrize(
    ("name", "fmt"),
    [("cal.script", "urscript"), ("CAL.src", "krl"), ("cal.mod", "rapid"), ("cal.ls", "fanuc-ls")],
)
def test_cli_picks_the_format_from_the_extension(tmp_path, plan_csv, name, fmt):
    done = cli("program", plan_csv, "-o", name, "--pulse", "1", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert f"({fmt})" in done.stdout
    parsed = PARSERS[fmt]((tmp_path / name).read_text())
    path = planning.read_plan(plan_csv).path_rad
    np.testing.assert_allclose(parsed.targets()[1:-1], path, atol=1e-6)


def test_cli_names_the_program_after_its_file(tmp_path, plan_csv):
    assert cli("program", plan_csv, "-o", "calib_42.src", cwd=tmp_path).code == 0
    assert (tmp_path / "calib_42.src").read_text().startswith("DEF CALIB_42()")


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (("-o", "x.txt"), "cannot tell the format"),
        (("-o", "x.src", "--format", "rapid"), "does not end in .mod"),
        (("-o", "x.mod", "--speed", "1.5"), "above the ur10e ceiling"),
        (("-o", "x.mod", "--home", "1,2,3"), "--home needs six joint angles"),
        (("-o", "x.mod", "--home", "0,0,0,0,0,900"), "joint"),
        (("-o", "plan.csv", "--format", "csv"), "plan.csv"),
    ],
)
def test_cli_bad_input_is_one_line_and_writes_nothing(tmp_path, plan_csv, args, needle):
    before = plan_csv.read_bytes()
    line = one_line_error(cli("program", plan_csv, *args, cwd=tmp_path))
    assert needle in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv"]
    assert plan_csv.read_bytes() == before


def test_measure_external_refuses_the_embedded_simulated_tracker(tmp_path, plan_csv):
    line = one_line_error(
        cli("measure", "--robot", "external", "--plan", plan_csv, "-o", "s.parquet", cwd=tmp_path)
    )
    assert "--robot: external watches a tracker" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.csv"]


@pytest.mark.parametrize("option", ["--stop-band", "--settle-window", "--match-tolerance"])
def test_measure_external_options_refuse_non_positive_values(tmp_path, plan_csv, option):
    line = one_line_error(
        cli("measure", "--robot", "external", "--plan", plan_csv, option, "0", cwd=tmp_path)
    )
    assert option in line


# ---------------------------------------------------------------- vias


def _vias(q):
    """Two vias before pose 1 and one before pose 3 (rad), inside the limits."""
    via = [np.zeros((0, 6)) for _ in q]
    via[1] = np.array([q[0] * 0.5, q[1] * 0.5])
    via[3] = (q[2] * 0.25)[None]
    return tuple(via)


@pytest.mark.parametrize("fmt", ["urscript", "krl", "rapid", "fanuc-ls"])
def test_vias_are_moves_without_dwell_or_pulse_on_the_checked_path(fmt):
    q = _plan(6, seed=2)
    via = _vias(q)
    spec = _spec(q, via_rad=via)
    parsed = PARSERS[fmt](programs.render(spec, fmt))
    path = planning.Plan(q, via).path_rad
    targets = np.array(parsed.targets())
    # home, every via and pose in path order, home; joints within 1e-6 rad
    assert len(targets) == len(path) + 2
    np.testing.assert_allclose(targets[1:-1], path, rtol=0, atol=1e-6)
    # a dwell after each measured pose only: a via's move is followed by the next move
    measured = "mw"
    via_move = "m"
    expected = "m" + "".join(via_move * len(v) + measured for v in via) + "m"
    # (URScript sleeps through its pulse too: consecutive waits are one dwell)
    assert re.sub("w+", "w", parsed.order) == expected
    assert parsed.pulses == len(q)
    assert sum(parsed.waits) == pytest.approx(len(q) * spec.dwell_s, abs=1e-6)


def test_csv_table_names_the_vias(tmp_path):
    q = _plan(5)
    text = programs.render(_spec(q, via_rad=_vias(q)), "csv")
    rows = list(csv.DictReader(io.StringIO(text)))
    kinds = [(r["kind"], r["pose"], float(r["dwell_s"])) for r in rows]
    dwell = 1.75
    assert kinds == [
        ("home", "", 0.0),
        ("pose", "0", dwell),
        ("via", "1", 0.0),
        ("via", "1", 0.0),
        ("pose", "1", dwell),
        ("pose", "2", dwell),
        ("via", "3", 0.0),
        ("pose", "3", dwell),
        ("pose", "4", dwell),
        ("home", "", 0.0),
    ]


@pytest.mark.parametrize("fmt", ["urscript", "fanuc-ls"])
def test_cli_writes_a_plan_with_vias(tmp_path, fmt, checked_plan):
    planning.write_plan(tmp_path / "plan.csv", checked_plan)
    name = {"urscript": "cal.script", "fanuc-ls": "cal.ls"}[fmt]
    done = cli("program", "plan.csv", "-o", name, cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert f"10 poses and {checked_plan.n_vias} vias" in done.stdout
    parsed = PARSERS[fmt]((tmp_path / name).read_text())
    np.testing.assert_allclose(parsed.targets()[1:-1], checked_plan.path_rad, rtol=0, atol=1e-6)
    assert len(parsed.waits) == 10
