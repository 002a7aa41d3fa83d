"""``verify --path --robot external``: what it cannot do is refused in one line, and a
program that never moves ends the run naming what to check (a real tracker simulator)."""

from __future__ import annotations

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator import robots
from calibrator.errors import CalibrationError
from calibrator.model import frames
from calibrator.verify import path as verify_path
from calibrator.verify import path_external, pose
from drivers.tracker.line.device import LaserTracker
from drivers.tracker.line.simulator.launch import SimulatorProcess

TRACKER = ("--tracker", "socket://127.0.0.1:9")  # nothing listens: nothing may connect


@pytest.mark.parametrize(
    "args, message",
    [
        ((), "--robot external runs the path test only"),
        (("--path", "line"), "--robot external --path watches a tracker the arm's program moves"),
        (("--path", "line", *TRACKER, "--path-speed", "50%"), "give the mm/s"),
        (("--path", "line", *TRACKER), "--path needs a registration"),
    ],
)
def test_what_the_external_path_test_cannot_do_is_refused_in_one_line(tmp_path, args, message):
    done = cli("verify", "--robot", "external", *args, "-o", "v.json", cwd=tmp_path)
    assert done.code == 2, done.stdout
    assert message in one_line_error(done)
    assert not (tmp_path / "v.json").exists()


@pytest.mark.timeout(120)
def test_a_program_that_never_moves_ends_the_run_naming_what_to_check():
    arm = robots.get("ur10e")
    tool = frames.transform(translation=(0.0, 0.0, 100.0))
    vplan = pose.make_plan(arm, tool, 2)
    test = verify_path.plan_path(
        arm, tool, "line", vplan.cube, vplan.desired[0][:3, :3], vplan.q_test[0], 200.0
    )
    with SimulatorProcess(seed=1, initialised=True) as sim:
        sim.set_target([2500.0, 300.0, -200.0])  # a reflector that stays where it is
        tracker = LaserTracker(sim.url)
        tracker.connect()
        try:
            with pytest.raises(CalibrationError, match="0 of 2 cycles of the line seen"):
                path_external.run(tracker, test, 2, np.eye(4), wait_s=1.0)
        finally:
            tracker.close()
