"""The simulated controller: trapezoidal synchronous moves within the caps; its program order."""

import numpy as np
import pytest

from calibrator import robots
from calibrator.languages.spec import move_duration_s
from drivers.robot.external_sim.motion import JointMove, trapezoid_duration
from drivers.robot.external_sim.player import Hold, Player, PlayerOptions


@pytest.mark.parametrize("lead", [0.05, 0.5, 2.0, 5.0])
def test_a_move_keeps_to_its_speed_and_acceleration_and_ends_on_time(lead):
    start = np.zeros(6)
    end = np.array([lead, -0.5 * lead, 0.2 * lead, 0.0, lead * 0.9, -lead])
    move = JointMove(start, end, 1.0, 2.0)
    t = np.linspace(0.0, move.duration, 4001)
    q = move.at(t)
    dt = t[1] - t[0]
    speed = np.abs(np.diff(q, axis=0)) / dt
    accel = np.abs(np.diff(q, n=2, axis=0)) / dt**2
    assert speed.max() <= 1.0 + 1e-6
    assert accel.max() <= 2.0 * 1.01  # finite differences round the corners
    np.testing.assert_allclose(q[0], start, atol=1e-12)
    np.testing.assert_allclose(q[-1], end, atol=1e-12)
    # synchronous: every joint is the same fraction of its way at every instant
    fraction = (q - start)[:, 0] / (end - start)[0]
    np.testing.assert_allclose((q - start)[:, 1] / (end - start)[1], fraction, atol=1e-12)
    # the program writers time a move with the same profile
    assert move.duration == pytest.approx(move_duration_s(start, end, 1.0, 2.0))


def test_short_moves_are_triangular():
    assert trapezoid_duration(0.5, 1.0, 2.0) == pytest.approx(2 * np.sqrt(0.25))
    assert trapezoid_duration(2.0, 1.0, 2.0) == pytest.approx(2.0 + 0.5)


def test_the_script_skips_pauses_and_returns_home():
    plan = np.linspace(0.1, 1.0, 5)[:, None] * np.ones((1, 6))
    options = PlayerOptions(dwell_s=1.5, skip=(2,), pauses=((3, 0.5, 2.0),))
    script = Player(plan, np.zeros((6, 5)), np.eye(4), np.eye(4), options).script()
    holds = [s for s in script if isinstance(s, Hold)]
    stood = [tuple(np.round(h.q_rad, 6)) for h in holds]
    midway = tuple(np.round(0.5 * (plan[1] + plan[3]), 6))
    expected = [plan.mean(axis=0), plan[0], plan[1], midway, plan[3], plan[4], plan.mean(axis=0)]
    assert stood == [tuple(np.round(q, 6)) for q in expected]
    assert [h.seconds for h in holds] == [0.0, 1.5, 1.5, 2.0, 1.5, 1.5, 1.5]


def test_poses_not_in_the_plan_are_refused():
    with pytest.raises(ValueError, match="not in the plan"):
        Player(np.zeros((3, 6)), np.zeros((6, 5)), np.eye(4), np.eye(4), PlayerOptions(skip=(5,)))


def test_vias_are_passed_through_without_a_dwell():
    plan = np.linspace(0.1, 1.0, 4)[:, None] * np.ones((1, 6))
    via = [np.zeros((0, 6)) for _ in plan]
    via[2] = np.array([np.full(6, -0.3), np.full(6, -0.6)])
    options = PlayerOptions(dwell_s=1.5)
    script = Player(plan, np.zeros((6, 5)), np.eye(4), np.eye(4), options, via_rad=via).script()
    ends = [np.round(s.end if isinstance(s, JointMove) else s.q_rad, 6) for s in script]
    kinds = ["move" if isinstance(s, JointMove) else "hold" for s in script]
    # the arm goes through both vias, in order, between poses 1 and 2, standing at neither
    at = [i for i, q in enumerate(ends) if np.allclose(q, -0.3) or np.allclose(q, -0.6)]
    assert [kinds[i] for i in at] == ["move", "move"]
    assert at[1] == at[0] + 1
    np.testing.assert_allclose(ends[at[0] - 1], plan[1])
    assert kinds[at[1] + 1] == "move" and np.allclose(ends[at[1] + 1], plan[2])
    holds = [s for s in script if isinstance(s, Hold)]
    assert len(holds) == len(plan) + 2  # start, a dwell per pose, end


def _played(player):
    """Points sent and wall seconds taken by ``player.play`` on a clock that only sleeps moves."""
    now, sent = [0.0], []
    player.play(sent.append, clock=lambda: now[0], sleep=lambda s: now.__setitem__(0, now[0] + s))
    return np.array(sent), now[0]


def test_a_time_scale_plays_the_same_program_that_many_times_faster():
    plan = np.linspace(0.1, 1.0, 4)[:, None] * np.ones((1, 6))
    arm, tool = robots.get("ur10e").mdh, np.eye(4)
    tool[:3, 3] = [10.0, -5.0, 100.0]  # the reflector off the flange: every joint moves it
    common = dict(dwell_s=1.5, pauses=((2, 0.5, 1.0),), vibration_mm=0.3, start_delay_s=0.5)
    real = Player(plan, arm, tool, np.eye(4), PlayerOptions(**common, tick_s=0.08))
    fast = Player(plan, arm, tool, np.eye(4), PlayerOptions(**common, tick_s=0.02, time_scale=4))
    real_points, real_s = _played(real)
    fast_points, fast_s = _played(fast)
    # the same controller time between updates (4 x 0.02 s = 0.08 s): the same stream
    assert len(real_points) > 100 and np.ptp(real_points, axis=0).min() > 100.0  # it moved
    np.testing.assert_allclose(fast_points, real_points, rtol=0, atol=1e-9)
    program_s = sum(s.duration if isinstance(s, JointMove) else s.seconds for s in real.script())
    assert real_s == pytest.approx(program_s)
    assert fast_s == pytest.approx(program_s / 4)


def test_a_time_scale_must_be_positive():
    with pytest.raises(ValueError, match="time_scale"):
        PlayerOptions(time_scale=0.0)
