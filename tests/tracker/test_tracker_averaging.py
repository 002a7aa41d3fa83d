"""measure_average: mean, spread and count of N readings; never a partial average."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from tracker_kit import CONNECT_PAIRS, expected_exchange, host, trk

from drivers.tracker import BeamBroken, TargetUnstable, measure_average


def meas_pairs(bodies, first_seq=4):
    return [
        (host(first_seq + i, "MEAS"), trk(f"OK,{first_seq + i},{b}")) for i, b in enumerate(bodies)
    ]


def test_mean_spread_and_count_over_the_wire():
    bodies = [f"P3,{x:.4f},2.0000,3.0000,ACC,{i}" for i, x in enumerate([1.0, 1.01, 1.02, 1.03])]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4)
    np.testing.assert_allclose(avg.mean_mm, [1.015, 2.0, 3.0])
    np.testing.assert_allclose(avg.std_mm, [np.std([1.0, 1.01, 1.02, 1.03], ddof=1), 0, 0])
    assert (avg.count, avg.rejected, len(avg.readings)) == (4, 0, 4)
    assert avg.rotvec_mean_rad is None


def test_flagged_readings_are_rejected_by_default():
    bodies = [
        "P3,1.0000,0.0000,0.0000,ACC,1",
        "P3,1.0400,0.0000,0.0000,UNSTABLE,2",
        "P3,1.0200,0.0000,0.0000,ACC,3",
        "P3,1.0600,0.0000,0.0000,INACC,4",
    ]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4)
    assert avg.mean_mm[0] == pytest.approx(1.01) and avg.count == 2 and avg.rejected == 2
    assert avg.outliers == 0 and "2 flagged" in avg.notes[0]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4, reject_flagged=False)
    assert avg.mean_mm[0] == pytest.approx(1.03) and avg.count == 4


def test_beam_break_mid_set_raises_and_stops_measuring():
    bodies = ["P3,1.0000,0.0000,0.0000,ACC,1", "P3,1.0000,0.0000,0.0000,ACC,2"]
    pairs = [
        *CONNECT_PAIRS,
        *meas_pairs(bodies),
        (host(6, "MEAS"), trk("ER,6,6,BEAM_BROKEN")),
    ]  # no pairs after the break: a further MEAS would fail the script
    with expected_exchange(pairs) as tracker:
        tracker.connect()
        with pytest.raises(BeamBroken):
            measure_average(tracker, 10)


def test_too_few_accepted_readings():
    bodies = ["P3,1.0000,0.0000,0.0000,UNSTABLE,1"] * 2 + ["P3,1.0000,0.0000,0.0000,ACC,3"]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        with pytest.raises(TargetUnstable, match="only 1 of 3 readings usable, need 2; 2 flagged"):
            measure_average(tracker, 3)


def test_orientation_mean_of_a_6dof_probe():
    rotvecs = Rotation.from_rotvec([0.5, 0.0, 0.0]) * Rotation.from_rotvec(
        [[0.001, 0, 0], [-0.001, 0, 0], [0, 0.002, 0], [0, -0.002, 0]]
    )
    bodies = [
        "P6,1.0000,2.0000,3.0000," + ",".join(f"{v:.8f}" for v in rv) + f",ACC,{i}"
        for i, rv in enumerate(rotvecs.as_rotvec())
    ]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4)
    np.testing.assert_allclose(avg.rotvec_mean_rad, [0.5, 0, 0], atol=1e-7)
    assert avg.rotvec_std_rad[1] > avg.rotvec_std_rad[0] > 0 and avg.rotvec_std_rad[2] < 1e-7


def test_n_must_be_positive():
    with pytest.raises(ValueError):
        measure_average(object(), 0)


def test_default_set_is_ten_readings_and_a_short_one_is_a_typed_tracker_error():
    bodies = [f"P3,{i / 1000:.4f},0.0000,0.0000,ACC,{i}" for i in range(10)]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker)  # exactly ten MEAS: an eleventh fails the script
    assert avg.count == 10 and avg.mean_mm[0] == pytest.approx(0.0045)
    flagged = ["P3,1.0000,0.0000,0.0000,UNSTABLE,1"] + ["P3,1.0000,0.0000,0.0000,ACC,2"] * 2
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(flagged)]) as tracker:
        tracker.connect()
        assert measure_average(tracker, 3, min_count=2).count == 2  # min_count passed on
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(flagged)]) as tracker:
        tracker.connect()
        with pytest.raises(TargetUnstable) as short:
            measure_average(tracker, 3, min_count=3)
    error = short.value
    assert (error.code, error.text, error.command) == (7, "TARGET_UNSTABLE", "MEAS")
    assert "2 of 3" in error.detail


def test_the_driver_module_hands_out_the_domain_result_type_and_nothing_else():
    import drivers.tracker.averaging as driver_averaging
    from calibrator.acquire.averaging import AveragedReading

    assert driver_averaging.AveragedReading is AveragedReading
    with pytest.raises(AttributeError, match="has no attribute 'averaged_reading'"):
        driver_averaging.averaged_reading  # noqa: B018 (the lookup is the test)


def _bodies(xs, flag="ACC"):
    return [f"P3,{x:.4f},300.0000,-200.0000,{flag},{i}" for i, x in enumerate(xs)]


QUIET = [2000.0 + 0.001 * k for k in (0, 3, -2, 1, -4, 2, -1, 4, -3, 0)]  # +-4 um


def test_one_wild_reading_of_ten_is_rejected_as_an_outlier_and_named():
    wild = list(QUIET)
    wild[6] += 50.0  # one reading of ten shifted 50 mm (a proxy's doing)
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(_bodies(wild))]) as tracker:
        tracker.connect()
        avg = measure_average(tracker)
    assert (avg.count, avg.rejected, avg.outliers) == (9, 1, 1)
    good = np.delete(np.array(QUIET), 6)
    assert avg.mean_mm[0] == pytest.approx(good.mean(), abs=1e-9)
    assert avg.std_mm[0] == pytest.approx(good.std(ddof=1), abs=1e-9)
    assert "1 outlier(s)" in avg.notes[0]


def test_a_quiet_tracker_keeps_its_good_readings_thanks_to_the_accuracy_floor():
    # MAD here is 0.5 um: 3.5 robust sigmas without a floor would reject the 10-um reading.
    xs = [2000.0, 2000.0, 2000.0, 2000.001, 1999.999, 2000.0, 2000.0, 2000.001, 2000.0, 2000.010]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(_bodies(xs))]) as tracker:
        tracker.connect()
        avg = measure_average(tracker)
    assert (avg.count, avg.outliers) == (10, 0) and avg.notes == ()


def test_a_set_split_in_two_is_refused_as_unstable_and_says_why():
    xs = [2000.0] * 5 + [2000.5] * 5  # no outlier by the rule, but the target moved
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(_bodies(xs))]) as tracker:
        tracker.connect()
        with pytest.raises(TargetUnstable, match=r"spread 0\.2635 mm over 10 readings exceeds"):
            measure_average(tracker)


def test_outliers_that_leave_too_few_refuse_the_set_and_say_why():
    from calibrator.acquire.averaging import TooFewReadings, average, inlier_mask

    xs = [*QUIET[:4], 2100.0]  # n=5, all five needed: the wild one leaves four
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(_bodies(xs))]) as tracker:
        tracker.connect()
        with pytest.raises(TargetUnstable, match=r"only 4 of 5 .* need 5; 1 outlier\(s\)"):
            measure_average(tracker, 5, min_count=5)
    pts = np.array([[x, 300.0, -200.0] for x in [*QUIET, 2003.0]])
    assert inlier_mask(pts).tolist() == [True] * 10 + [False]  # 3 mm off: out
    with pytest.raises(TooFewReadings, match="only 0 of 0"):
        average([])


def test_non_finite_readings_never_enter_the_mean():
    from calibrator.acquire.averaging import TooFewReadings, average

    class R:
        def __init__(self, x):
            self.point_mm, self.rotvec_rad, self.accurate = np.array([x, 0.0, 0.0]), None, True

    avg = average([R(1000.0), R(np.nan), R(1000.002), R(np.inf), R(1000.001)])
    assert avg.count == 3 and avg.mean_mm[0] == pytest.approx(1000.001)
    assert "2 non-finite" in avg.notes[0]
    with pytest.raises(TooFewReadings, match="only 1 of 3"):
        average([R(1e300 * 10), R(np.nan), R(5.0)])


class _Drifting:
    """A target that creeps 0.1 mm per reading for the first ``drifting`` readings."""

    def __init__(self, drifting):
        self.n, self.drifting = 0, drifting

    def measure(self, timeout_s=None):
        from types import SimpleNamespace

        self.n += 1
        creep = 0.1 * min(self.n, self.drifting)
        return SimpleNamespace(
            point_mm=np.array([2000.0 + creep, 300.0, -200.0]), rotvec_rad=None, accurate=True
        )


class _Arm:
    def move_joints(self, q, speed, accel):
        return np.asarray(q, dtype=float)

    def actual_joints(self):
        return np.zeros(6)


def test_the_loop_re_measures_an_unstable_pose_and_journals_why_when_it_gives_up():
    from calibrator.acquire import loop

    journal = []
    sink = type("J", (), {"append": lambda self, r: journal.append(r)})()
    options = loop.LoopOptions(readings=10, retries=1)
    out = loop.run(np.zeros((1, 6)), _Arm(), _Drifting(10), sink, options)
    assert out.measured == [0] and journal[0]["attempts"] == 2  # the still second set
    assert journal[0]["std_mm"][0] < 0.001
    out = loop.run(np.zeros((1, 6)), _Arm(), _Drifting(10**6), sink, options)
    assert out.failed == [0] and journal[1]["status"] == "failed"
    assert journal[1]["reason"].count("UnstablePose: spread") == 2
    assert "exceeds the limit" in journal[1]["reason"]
