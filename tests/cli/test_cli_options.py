"""Every option is checked before work starts: one line naming it, exit 2."""

import json
import math
import re

import pytest
from cli_kit import cli, listing, one_line_error
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.main import get_command

from calibrator.cli import app


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    """A 30-pose session and a 4-pose one, written once for the module."""
    folder = tmp_path_factory.mktemp("sessions")
    assert cli("simulate", "-o", "s.parquet", "--poses", "30", cwd=folder).code == 0
    assert cli("simulate", "-o", "few.parquet", "--poses", "4", cwd=folder).code == 0
    return folder


@pytest.mark.parametrize(
    "args, option, says",
    [
        (["--k", "nan"], "--k", "finite"),
        (["--k", "inf"], "--k", "finite"),
        (["--orientation-weight", "nan"], "--orientation-weight", "finite"),
        (["--orientation-weight", "-1"], "--orientation-weight", ">= 0"),
        (["--particles", "0"], "--particles", ">= 2"),
        (["--particles", "abc"], "--particles", "not a whole number"),
        (["--generations", "-1"], "--generations", ">= 0"),
        (["--validation-fraction", "1.5"], "--validation-fraction", "[0, 1)"),
        (["--validation-fraction", "-0.1"], "--validation-fraction", "[0, 1)"),
        (["--validation-fraction", "nan"], "--validation-fraction", "finite"),
        (["--seed", "-1"], "--seed", ">= 0"),
        (["--method", "foo"], "--method", "'foo' is not one of"),
    ],
)
def test_bad_identify_options_are_one_line(sessions, args, option, says):
    before = listing(sessions)
    line = one_line_error(cli("identify", "s.parquet", "-o", "x.json", *args, cwd=sessions))
    assert f"error: {option}: " in line and says in line
    assert "Value error" not in line and "Input should" not in line
    assert listing(sessions) == before


@pytest.mark.parametrize(
    "command, args, option",
    [
        ("simulate", ["--poses", "0"], "--poses"),
        ("simulate", ["--noise-mm", "-0.1"], "--noise-mm"),
        ("simulate", ["--noise-mm", "inf"], "--noise-mm"),
        ("simulate", ["--orientation-noise-deg", "nan"], "--orientation-noise-deg"),
        ("simulate", ["--joint-noise-rad", "-1"], "--joint-noise-rad"),
        ("simulate", ["--tool-offset-mm", "nan"], "--tool-offset-mm"),
        ("simulate", ["--seed", "-3"], "--seed"),
        ("simulate", ["--errors", "bad"], "--errors"),
        ("simulate", ["--frame", "world"], "--frame"),
        ("export-params", ["c.json", "--format", "yaml"], "--format"),
    ],
)
def test_bad_options_of_other_commands(tmp_path, command, args, option):
    line = one_line_error(cli(command, *args, "-o", "out.x", cwd=tmp_path))
    assert f"error: {option}: " in line
    assert "Value error" not in line
    assert list(tmp_path.iterdir()) == []


def test_version_and_short_help(tmp_path):
    version = cli("--version", cwd=tmp_path)
    assert version.code == 0 and version.stdout.startswith("calibrator ")
    for args in (["-h"], ["identify", "-h"], ["report", "-h"]):
        shown = cli(*args, cwd=tmp_path)
        assert shown.code == 0 and "Usage: calibrator" in shown.stdout
    assert "--k" not in cli("identify", "-h", cwd=tmp_path).stdout  # hidden old name


def test_every_visible_option_has_help_text():
    group = get_command(app)
    for name, command in group.commands.items():
        for param in command.params:
            if getattr(param, "hidden", False) or param.name == "help":
                continue
            assert getattr(param, "help", None), f"{name} {param.opts} has no help text"


def test_unknown_option_and_missing_argument(tmp_path):
    assert "No such option: --bogus" in one_line_error(
        cli("identify", "s.parquet", "--bogus", cwd=tmp_path)
    )
    assert "Missing argument 'SESSION'" in one_line_error(cli("identify", cwd=tmp_path))


def test_old_k_still_works_and_both_names_are_refused(sessions, tmp_path):
    out = tmp_path / "c.json"
    ok = cli("identify", "s.parquet", "--method", "lm", "--k", "250", "-q", "-o", out, cwd=sessions)
    assert ok.code == 0, ok.stderr
    assert json.loads(out.read_text())["k"] == 250.0
    both = cli("identify", "s.parquet", "--k", "1", "--orientation-weight", "2", cwd=sessions)
    assert "--orientation-weight" in one_line_error(both)


def test_three_pose_message_names_file_and_option(sessions):
    line = one_line_error(cli("identify", "few.parquet", cwd=sessions))
    assert line.startswith("calibrator: error: few.parquet: ") and "from 3 fitting poses" in line
    assert "the fitting" not in line
    assert "--validation-fraction 0.2" in line and "1 of 4 poses held out" in line


def test_wording_counts_one_pose(tmp_path):
    done = cli("simulate", "-o", "one.parquet", "--poses", "1", cwd=tmp_path)
    assert "(1 pose," in done.stdout
    line = one_line_error(cli("identify", "one.parquet", cwd=tmp_path))
    assert "1 fitting pose:" in line


def test_errors_seed_is_the_old_name_of_ref003(tmp_path):
    import pyarrow.parquet as pq

    for name in ("seed", "ref003"):
        done = cli(
            "simulate", "-o", f"{name}.parquet", "--poses", "3", "--errors", name, cwd=tmp_path
        )
        assert done.code == 0, done.stderr
        meta = json.loads(pq.read_schema(tmp_path / f"{name}.parquet").metadata[b"calibrator"])
        assert meta["simulated"]["errors"] == "ref003"
    assert "ref003 error table" in one_line_error(
        cli("simulate", "--model", "ur5e", "--errors", "ref003", cwd=tmp_path)
    )


# Fuzz: any text for a numeric option is either accepted (then the command goes
# on and fails on the missing session file) or refused naming the option.
_NUMBERS = st.one_of(
    st.integers(-(10**6), 10**6).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["nan", "-inf", "inf", "1e999", "", " ", "0x10", "1_000", "abc", "--"]),
    st.text(max_size=6),
)
_RULES = {
    "--particles": lambda v: float(v) == int(float(v)) and 2 <= int(float(v)) <= 1_000,
    "--generations": lambda v: float(v) == int(float(v)) and 0 <= int(float(v)) <= 100_000,
    "--orientation-weight": lambda v: math.isfinite(v) and 0 <= v <= 1e12,
    "--validation-fraction": lambda v: math.isfinite(v) and 0 <= v < 1,
    "--seed": lambda v: float(v) == int(float(v)) and 0 <= int(float(v)) <= 2**63 - 1,
}


_INTS = ("--particles", "--generations", "--seed", "--poses")


def _canonical(option, value):
    """A plain spelling of a number (where acceptance must follow the rule exactly)."""
    if option in _INTS:
        return re.fullmatch(r"-?[0-9]+", value) is not None
    try:
        return repr(float(value)) == value
    except ValueError:
        return False


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(option=st.sampled_from(sorted(_RULES)), value=_NUMBERS)
def test_fuzz_numeric_options(tmp_path, option, value):
    result = cli("identify", "missing.parquet", f"{option}={value}", cwd=tmp_path)
    line = one_line_error(result)
    accepted = "session file not found" in line
    if accepted:
        assert _RULES[option](float(value)), (option, value)  # only valid values get through
    else:
        assert f"error: {option}: " in line, line
    if _canonical(option, value):
        assert accepted == _RULES[option](float(value)), (option, value, line)
    assert list(tmp_path.iterdir()) == []


_SIMULATE_RULES = {
    "--poses": lambda v: float(v) == int(float(v)) and 1 <= int(float(v)) <= 50_000,
    "--seed": lambda v: float(v) == int(float(v)) and 0 <= int(float(v)) <= 2**63 - 1,
    "--noise-mm": lambda v: math.isfinite(v) and 0 <= v <= 100,
    "--orientation-noise-deg": lambda v: math.isfinite(v) and 0 <= v <= 10,
    "--joint-noise-rad": lambda v: math.isfinite(v) and 0 <= v <= 0.1,
    "--tool-offset-mm": lambda v: math.isfinite(v) and 0 <= v <= 2000,
}


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(option=st.sampled_from(sorted(_SIMULATE_RULES)), value=_NUMBERS)
def test_fuzz_simulate_options(tmp_path, option, value):
    # Valid options reach the output check, which refuses the missing folder.
    result = cli("simulate", f"{option}={value}", "-o", "nodir/s.parquet", cwd=tmp_path)
    line = one_line_error(result)
    accepted = "folder nodir does not exist" in line
    if accepted:
        assert _SIMULATE_RULES[option](float(value)), (option, value)
    else:
        assert f"error: {option}: " in line, line
    if _canonical(option, value):
        assert accepted == _SIMULATE_RULES[option](float(value)), (option, value, line)
    assert list(tmp_path.iterdir()) == []


def test_measure_and_verify_take_the_shared_run_options_alike_in_the_same_place(tmp_path):
    # Declared once (cli/_run.py RunArgs): same flags, defaults, help and checks in
    # both commands, listed where each command's own options put them.
    commands = get_command(app).commands
    shared = [
        "resume", "yes", "force", "model", "base_link", "tip_link", "settle", "retries",
        "speed", "accel", "max_speed",
    ]  # fmt: skip
    seen = {}
    for name in ("measure", "verify"):
        params = {p.name: p for p in commands[name].params}
        order = [p.name for p in commands[name].params]
        start = order.index("resume")
        assert order[start : start + len(shared)] == shared, name
        seen[name] = [
            (params[n].opts, params[n].default, params[n].help, params[n].callback) for n in shared
        ]
    for (opts, default, text, check), (opts2, default2, text2, check2) in zip(
        seen["measure"], seen["verify"], strict=True
    ):
        assert (opts, default, text) == (opts2, default2, text2)
        assert (check is None) == (check2 is None)
    for name in ("measure", "verify"):  # and each checks them against the model's ceiling
        line = one_line_error(cli(name, "--speed", "5", cwd=tmp_path))
        assert "--speed 5.0 rad/s outside (0, " in line, line
    assert listing(tmp_path) == {}
