"""``verify --path-speed PCT%``: the standard's speeds as shares of the path's rated speed."""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator import robots
from calibrator.model import frames
from calibrator.verify import iso9283
from calibrator.verify import path as verify_path
from calibrator.verify import pose as pose_run


def test_the_rated_speed_brings_the_leading_joint_to_its_ceiling():
    arm = robots.get("ur10e")
    tool = frames.transform(translation=(0.0, 0.0, 100.0))
    vplan = pose_run.make_plan(arm, tool, 2, None, None, (2000.0, 0.0, 500.0), None)
    args = (arm, tool, "line", vplan.cube, vplan.desired[0][:3, :3], vplan.q_test[0])
    rated = verify_path.rated_speed_mm_s(arm, verify_path.plan_path(*args, 100.0))
    at_rated = verify_path.plan_path(*args, rated)
    speeds = np.abs(np.diff(at_rated.q, axis=0) / np.diff(at_rated.t_s)[:, None])
    ceiling = np.minimum(arm.move_speed_cap_rad_s, arm.max_joint_speed_rad_s)
    # At the rated speed one joint runs at its ceiling (to the 4 ms sampling of the commands).
    assert np.max(speeds / ceiling) == pytest.approx(1.0, rel=5e-3)
    # The same path planned at another speed gives the same rated speed.
    again = verify_path.rated_speed_mm_s(arm, verify_path.plan_path(*args, 37.0))
    assert again == pytest.approx(rated, rel=5e-3)
    assert isinstance(vplan.cube, iso9283.Cube)


def test_percent_speeds_are_shares_of_the_rated_speed(tmp_path):
    docs = {}
    for pct in ("100%", "50%"):
        done = cli(
            "verify", "--seed", "3", "--path", "line", "--cycles", "2", "--path-speed", pct,
            "-o", f"v{pct[:-1]}.json", cwd=tmp_path,
        )  # fmt: skip
        assert done.code == 0, done.stderr
        assert f"{pct[:-1]} % of its rated" in done.stdout
        docs[pct] = json.loads((tmp_path / f"v{pct[:-1]}.json").read_text())["path"]
    full, half = docs["100%"], docs["50%"]
    assert full["rated_speed_mm_s"] == pytest.approx(half["rated_speed_mm_s"])
    assert full["speed_mm_s"] == pytest.approx(full["rated_speed_mm_s"])
    assert half["speed_mm_s"] == pytest.approx(0.5 * full["rated_speed_mm_s"])
    assert full["speed_pct"] == pytest.approx(100.0) and half["speed_pct"] == pytest.approx(50.0)
    # A kinematic arm keeps its speed at either: AV within a fraction of a percent.
    assert abs(full["AV_pct"]) < 1.0 and abs(half["AV_pct"]) < 1.0


def test_a_plain_number_is_still_mm_s(tmp_path):
    done = cli(
        "verify", "--seed", "3", "--path", "line", "--cycles", "2", "--path-speed", "400",
        "-o", "v.json", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    path = json.loads((tmp_path / "v.json").read_text())["path"]
    assert path["speed_mm_s"] == 400.0
    assert path["speed_pct"] == pytest.approx(100 * 400.0 / path["rated_speed_mm_s"])


@pytest.mark.parametrize(
    "speed, message",
    [
        ("12x", "--path-speed must be mm/s or a percentage"),
        ("120%", "--path-speed must be in (0, 100] %"),
        ("0%", "--path-speed must be in (0, 100] %"),
        ("%", "--path-speed must be mm/s or a percentage"),
    ],
)
def test_speeds_it_cannot_read_are_refused_in_one_line(tmp_path, speed, message):
    done = cli("verify", "--path", "line", "--path-speed", speed, "-o", "v.json", cwd=tmp_path)
    assert message in one_line_error(done)
    assert not (tmp_path / "v.json").exists()
