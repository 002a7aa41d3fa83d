"""``measure --robot external``'s stop options: bounded, refused in one line before any work."""

import pytest
from cli_kit import cli, one_line_error


@pytest.mark.parametrize(
    ("option", "value", "message"),
    [
        ("--stop-timeout", "1e300", "--stop-timeout: 1e+300 s is more than the limit of 3600 s"),
        ("--settle-window", "1e300", "--settle-window: 1e+300 s is more than the limit of 10 s"),
        (
            "--match-tolerance",
            "1e300",
            "--match-tolerance: 1e+300 mm is more than the limit of 50 mm",
        ),
        ("--stop-band", "1e300", "--stop-band: 1e+300 mm is more than the limit of 1 mm"),
        ("--stop-band", "1.5", "--stop-band: 1.5 mm is more than the limit of 1 mm"),
        ("--stop-timeout", "0", "--stop-timeout: must be > 0, got 0.0"),
        ("--settle-window", "-1", "--settle-window: must be > 0, got -1.0"),
    ],
)
def test_an_unbounded_stop_option_is_one_line_exit_2(tmp_path, option, value, message):
    done = cli(
        "measure", "--robot", "external", "--tracker", "socket://127.0.0.1:1",
        "--plan", "plan.csv", option, value, cwd=tmp_path,
    )  # fmt: skip
    assert one_line_error(done) == f"calibrator: error: {message}"
    assert list(tmp_path.iterdir()) == []  # refused before anything was read or written


@pytest.mark.parametrize(
    ("option", "value"),
    [("--stop-timeout", "3600"), ("--settle-window", "10"), ("--match-tolerance", "50")],
)
def test_the_limits_themselves_are_accepted(tmp_path, option, value):
    done = cli(
        "measure", "--robot", "external", "--tracker", "socket://127.0.0.1:1",
        "--plan", "plan.csv", option, value, cwd=tmp_path,
    )  # fmt: skip
    # past the option checks: the missing plan is what is refused
    assert "plan.csv" in one_line_error(done)


def test_the_external_robot_without_a_plan_is_refused_before_anything(tmp_path):
    """No controller runs a plan measure would make itself: the plan file is required."""
    done = cli("measure", "--robot", "external", "--tracker", "socket://127.0.0.1:1", cwd=tmp_path)
    assert one_line_error(done).startswith("calibrator: error: --robot external needs --plan")
    assert list(tmp_path.iterdir()) == []
