"""The robot-stream alignment of the path test, on synthetic streams of known timing.

A robot stream (the model's tool path at the joints a controller reports,
sampled every 4 ms) and a tracker stream (500 Hz, stamped a known latency
late, off the model by a constant offset as a true arm is): the latency
comes back, and the offset does not pass for a time shift.
"""

import numpy as np
import pytest

from calibrator.verify import path as verify_path
from calibrator.verify import path_figures as ip

LINE = ip.line([400.0, -200.0, 300.0], [700.0, 100.0, 600.0])
SPEED = 200.0  # mm/s


def timed_line(t_s, t0_s):
    """The tool at ``t_s`` running LINE at SPEED from ``t0_s``, held at its ends."""
    return ip.commanded_reference(LINE, SPEED, t0_s)(np.asarray(t_s, float))


@pytest.mark.parametrize("offset_mm", [[0.0, 0.0, 0.0], [0.3, 0.2, -0.1]])
def test_the_tracker_latency_behind_the_robot_stream_is_recovered(offset_mm):
    rng = np.random.default_rng(7)
    duration = LINE.length_mm / SPEED
    arm_lag, latency = 0.003, 0.025
    # The robot's samples: irregular (a loaded host), the arm 3 ms behind its command.
    t_r = np.cumsum(rng.uniform(0.002, 0.008, 2000)) - 0.3
    t_r = t_r[t_r < duration + 0.3]
    p_r = timed_line(t_r, arm_lag)
    # The tracker's: 500 Hz, each reading showing the arm `latency` before its stamp,
    # the true arm `offset_mm` off the model, 10 um of noise.
    t_k = np.arange(-0.3, duration + 0.3, 0.002)
    p_k = timed_line(t_k - latency, arm_lag) + offset_mm + rng.normal(0.0, 0.01, (len(t_k), 3))
    found = verify_path.robot_latency(t_k, p_k, ip.stream_reference(t_r, p_r))
    assert found == pytest.approx(latency, abs=0.5e-3)
    # Without the offset taken out, a 0.3 mm offset along the line would have been 1.5 ms.
    plain = ip.estimate_latency(t_k, p_k, ip.stream_reference(t_r, p_r), verify_path.MAX_LATENCY_S)
    along = np.dot(offset_mm, LINE.tangent(np.array([0.0]))[0])
    assert plain == pytest.approx(latency - along / SPEED, abs=0.5e-3)


def test_timed_samples_note_when_each_tick_arrived():
    class Reading:
        def __init__(self, x):
            self.point_mm = np.array([x, 0.0, 0.0])

    class Tick:
        def __init__(self, n):
            self.n, self.device_time_us, self.code = n, 2000 * n, 0 if n % 3 else 6
            self.reading = Reading(float(n)) if self.code == 0 else None

    n, t_us, points, code, seen, rotvec = verify_path.timed_samples(
        iter(map(Tick, range(1, 10))), 5
    )
    assert n.tolist() == [1, 2, 3, 4, 5] and t_us.tolist() == [2000, 4000, 6000, 8000, 10000]
    assert code.tolist() == [0, 0, 6, 0, 0] and np.isnan(points[2]).all()
    assert points[:, 0].tolist()[:2] == [1.0, 2.0] and np.all(np.diff(seen) >= 0)
    assert rotvec is None  # a reflector's readings carry no orientation


def test_timed_samples_keep_a_probes_orientation_and_mark_the_gaps():
    class Reading:
        def __init__(self, x):
            self.point_mm = np.array([x, 0.0, 0.0])
            self.rotvec_rad = np.array([0.0, 0.0, 0.01 * x])

    class Tick:
        def __init__(self, n):
            self.n, self.device_time_us, self.code = n, 2000 * n, 0 if n % 3 else 6
            self.reading = Reading(float(n)) if self.code == 0 else None

    *_, rotvec = verify_path.timed_samples(iter(map(Tick, range(1, 10))), 5)
    assert rotvec is not None and rotvec.shape == (5, 3)
    assert rotvec[:, 2].tolist()[:2] == [0.01, 0.02] and rotvec[4, 2] == pytest.approx(0.05)
    assert np.isnan(rotvec[2]).all()
