"""Option checks at their boundaries, and the one-line wording of every usage error.

The commands build their callbacks when ``calibrator.cli`` is imported, so the
checks are also called here directly: accepted at the limit, refused just past
it, with the message the user reads.
"""

import math

import pytest
import typer
from cli_kit import cli, one_line_error
from typer._click import exceptions as click_errors

from calibrator.cli import _checks as checks
from calibrator.errors import CalibrationError


def refusal(check, value):
    with pytest.raises(typer.BadParameter) as caught:
        check(value)
    return caught.value.message


def test_at_least_accepts_the_limit_and_refuses_one_below():
    check = checks.at_least(2)
    assert check(2) == 2
    assert check(10**9) == 10**9
    assert check(None) is None
    assert refusal(check, 1) == "must be a whole number >= 2, got 1"
    assert checks.at_least(0)(0) == 0
    assert refusal(checks.at_least(0), -1) == "must be a whole number >= 0, got -1"


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_finite_refuses_nan_and_infinities_even_without_bounds(bad):
    assert refusal(checks.finite(), bad) == f"must be a finite number, got {bad}"
    assert refusal(checks.finite(0.0, 90.0), bad) == f"must be a finite number, got {bad}"


def test_finite_without_bounds_takes_any_finite_number():
    check = checks.finite()
    assert check(None) is None
    assert check(-1e300) == -1e300 and check(0.0) == 0.0 and check(1e300) == 1e300


def test_finite_lower_bound_inclusive_and_strict():
    inclusive = checks.finite(minimum=0.0)
    assert inclusive(0.0) == 0.0
    assert inclusive(1e-12) == 1e-12
    assert inclusive(1e300) == 1e300  # no upper bound
    assert refusal(inclusive, -1e-12) == "must be >= 0, got -1e-12"
    strict = checks.finite(minimum=0.0, inclusive=False)
    assert strict(1e-12) == 1e-12
    assert strict(1e300) == 1e300
    assert refusal(strict, 0.0) == "must be > 0, got 0.0"
    assert refusal(strict, -1.0) == "must be > 0, got -1.0"


def test_finite_upper_bound_inclusive_and_strict():
    inclusive = checks.finite(maximum=5.0)
    assert inclusive(5.0) == 5.0
    assert inclusive(-1e300) == -1e300  # no lower bound
    assert refusal(inclusive, 5.000001) == "must be <= 5, got 5.000001"
    strict = checks.finite(maximum=5.0, inclusive=False)
    assert strict(4.999999) == 4.999999
    assert strict(-1e300) == -1e300
    assert refusal(strict, 5.0) == "must be < 5, got 5.0"


def test_finite_between_two_bounds():
    inclusive = checks.finite(0.0, 90.0)
    assert inclusive(0.0) == 0.0 and inclusive(90.0) == 90.0 and inclusive(45.5) == 45.5
    assert refusal(inclusive, 90.5) == "must be in [0, 90], got 90.5"
    assert refusal(inclusive, -0.5) == "must be in [0, 90], got -0.5"
    strict = checks.finite(0.0, 90.0, inclusive=False)
    assert strict(0.5) == 0.5 and strict(89.5) == 89.5
    assert refusal(strict, 90.0) == "must be in (0, 90), got 90.0"
    assert refusal(strict, 0.0) == "must be in (0, 90), got 0.0"


def test_fraction_is_zero_up_to_but_not_including_one():
    check = checks.fraction()
    assert check(None) is None
    assert check(0.0) == 0.0
    assert check(0.999999) == 0.999999
    for bad in (1.0, -1e-9, math.nan, math.inf, -math.inf):
        assert refusal(check, bad) == f"must be a fraction in [0, 1), got {bad}"


def _usage_error(app, *args):
    with pytest.raises(click_errors.UsageError) as caught:
        app(args=list(args), standalone_mode=False, prog_name="prog")
    return caught.value


def test_typer_range_and_type_errors_read_plainly():
    app = typer.Typer()

    @app.command()
    def first(
        n: int = typer.Option(3, min=2, max=5),
        x: float = typer.Option(0.5, "-x", min=0.0, max=1.0),
    ):
        pass

    @app.command()
    def second(count: int):
        pass

    assert checks.one_line(_usage_error(app, "first", "--n", "1")) == "--n: must be >= 2, got '1'"
    assert checks.one_line(_usage_error(app, "first", "--n", "6")) == "--n: must be <= 5, got '6'"
    assert checks.one_line(_usage_error(app, "first", "-x", "2")) == "-x: must be <= 1, got '2'"
    assert (
        checks.one_line(_usage_error(app, "first", "--n", "q"))
        == "--n: not a whole number, got 'q'"
    )
    assert checks.one_line(_usage_error(app, "first", "-x", "q")) == "-x: not a number, got 'q'"
    assert (
        checks.one_line(_usage_error(app, "second", "1.5"))
        == "COUNT: not a whole number, got '1.5'"
    )
    # Not about a value: the error itself and where to find help.
    assert checks.one_line(_usage_error(app, "first", "--zzzz")) == (
        "No such option: --zzzz (see 'prog first -h')"
    )
    # Only the closing full stop goes: a message may end in a capital X.
    assert checks.one_line(_usage_error(app, "first", "-X")) == (
        "No such option: -X (see 'prog first -h')"
    )


def test_a_callback_refusal_keeps_its_own_wording_once():
    app = typer.Typer()

    @app.command()
    def only(k: float = typer.Option(None, "--k", callback=checks.finite(minimum=0.0))):
        pass

    error = _usage_error(app, "--k", "-2")
    assert checks.one_line(error) == "--k: must be >= 0, got -2.0"


def test_a_refusal_ending_in_a_capital_x_keeps_it():
    def refuse(value: int):
        raise typer.BadParameter(f"{value} is more than the axis limit MAX.")

    app = typer.Typer()

    @app.command()
    def only(n: int = typer.Option(0, "--n", callback=refuse)):
        pass

    assert (
        checks.one_line(_usage_error(app, "--n", "7")) == "--n: 7 is more than the axis limit MAX"
    )


def test_input_of_reads_the_typed_value_or_nothing():
    class Cause:
        def __init__(self, errors):
            self._errors = errors

        def errors(self):
            return self._errors

    assert checks._input_of(Cause([{"input": "abc"}])) == "abc"
    assert checks._input_of(Cause([])) is None
    assert checks._input_of(Cause([{"type": "x"}])) is None
    assert checks._input_of(None) is None


@pytest.mark.parametrize(
    ("args", "line"),
    [
        (("simulate", "--poses", "0"), "--poses: must be a whole number >= 1, got 0"),
        (("simulate", "--poses", "2.5"), "--poses: not a whole number, got '2.5'"),
        (
            ("simulate", "--noise-mm", "abc"),
            "--noise-mm: must be a finite decimal number, got 'abc'",
        ),
        (("simulate", "--noise-mm", "-1"), "--noise-mm: must be in [0, 100], got -1.0"),
        (
            ("export-params", "x.json", "--format", "yaml"),
            "--format: 'yaml' is not one of 'json', 'csv', 'ur-calibration', "
            "'ros-kinematics', 'urdf'",
        ),
        (
            ("simulate", "extra"),
            "Got unexpected extra argument(s) (extra) (see 'calibrator simulate -h')",
        ),
        (("identify",), "Missing argument 'SESSION' (see 'calibrator identify -h')"),
        (("report", "a.json", "-o"), "Option '-o' requires an argument"),
    ],
)
def test_command_line_errors_are_exact_single_lines(tmp_path, args, line):
    assert one_line_error(cli(*args, cwd=tmp_path)) == f"calibrator: error: {line}"


# --- calibrator.cli.main: every way a command ends -------------------------------


def _failing_load(monkeypatch, exc):
    from calibrator import calibration

    def load(path):
        raise exc

    monkeypatch.setattr(calibration, "load", load)


@pytest.mark.parametrize(
    ("exc", "code", "line"),
    [
        (typer.Abort(), 130, "interrupted"),
        (KeyboardInterrupt(), 130, "interrupted"),
        (OSError(13, "Permission denied", "c.json"), 2, "Permission denied: c.json"),
        (OSError(5, "Input/output error"), 2, "Input/output error"),
        (OSError(5, "Input/output error", "MATRIX"), 2, "Input/output error: MATRIX"),
        (OSError("no code"), 2, "no code"),
        (CalibrationError("c.json: bad\nsecond\r\nthird"), 2, "c.json: bad second  third"),
        (click_errors.ClickException("broken pipe"), 1, "broken pipe"),
    ],
)
def test_every_failure_is_one_line_with_its_exit_code(tmp_path, monkeypatch, exc, code, line):
    _failing_load(monkeypatch, exc)
    done = cli("report", "c.json", "-o", "rep", cwd=tmp_path)
    assert (done.code, done.stdout, done.stderr) == (code, "", f"calibrator: error: {line}\n")


def test_no_arguments_prints_help_and_succeeds(tmp_path):
    done = cli(cwd=tmp_path)
    assert (done.code, done.stderr) == (0, "")
    assert done.stdout.startswith("Usage: calibrator [OPTIONS] COMMAND [ARGS]...")
    assert "Calibrate 6-axis robot arms with a laser tracker in the loop." in done.stdout
    for command in ("plan", "measure", "identify", "report", "simulate"):
        assert f"  {command} " in done.stdout


def test_version_installed_or_not(tmp_path, monkeypatch):
    from importlib import metadata

    done = cli("--version", cwd=tmp_path)
    assert (done.code, done.stdout) == (0, f"calibrator {metadata.version('calibrator')}\n")

    def not_installed(name):
        raise metadata.PackageNotFoundError(name)

    monkeypatch.setattr(metadata, "version", not_installed)
    done = cli("--version", "report", cwd=tmp_path)  # eager: the rest is not run
    assert (done.code, done.stdout) == (0, "calibrator (version unknown: not installed)\n")


def test_a_command_ending_with_its_own_exit_code_keeps_it(tmp_path, monkeypatch):
    _failing_load(monkeypatch, typer.Exit(3))  # as compensate does for unreachable targets
    done = cli("report", "c.json", "-o", "rep", cwd=tmp_path)
    assert (done.code, done.stdout, done.stderr) == (3, "", "")
