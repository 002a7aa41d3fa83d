"""measure_average: mean, spread and count of N readings; never a partial average."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from tracker_testkit import CONNECT_PAIRS, expected_exchange, host, trk

from drivers.tracker import BeamBroken, TargetUnstable, measure_average


def meas_pairs(bodies, first_seq=4):
    return [
        (host(first_seq + i, "MEAS"), trk(f"OK,{first_seq + i},{b}")) for i, b in enumerate(bodies)
    ]


def test_mean_spread_and_count_over_the_wire():
    bodies = [f"P3,{x:.4f},2.0000,3.0000,ACC,{i}" for i, x in enumerate([1.0, 1.1, 1.2, 1.3])]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4)
    np.testing.assert_allclose(avg.mean_mm, [1.15, 2.0, 3.0])
    np.testing.assert_allclose(avg.std_mm, [np.std([1.0, 1.1, 1.2, 1.3], ddof=1), 0, 0])
    assert (avg.count, avg.rejected, len(avg.readings)) == (4, 0, 4)
    assert avg.rotvec_mean_rad is None


def test_flagged_readings_are_rejected_by_default():
    bodies = [
        "P3,1.0000,0.0000,0.0000,ACC,1",
        "P3,9.0000,0.0000,0.0000,UNSTABLE,2",
        "P3,3.0000,0.0000,0.0000,ACC,3",
        "P3,7.0000,0.0000,0.0000,INACC,4",
    ]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4)
    assert avg.mean_mm[0] == 2.0 and avg.count == 2 and avg.rejected == 2
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker, 4, reject_flagged=False)
    assert avg.mean_mm[0] == 5.0 and avg.count == 4


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
        with pytest.raises(TargetUnstable, match="only 1 of 3"):
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
    bodies = [f"P3,{i:.4f},0.0000,0.0000,ACC,{i}" for i in range(10)]
    with expected_exchange([*CONNECT_PAIRS, *meas_pairs(bodies)]) as tracker:
        tracker.connect()
        avg = measure_average(tracker)  # exactly ten MEAS: an eleventh fails the script
    assert avg.count == 10 and avg.mean_mm[0] == pytest.approx(4.5)
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
