"""Cases the check's other tests did not reach. Found by mutation testing (issue 44).

The circle test's own figures on a measured arm, its helpers at their edges
(a bin holding one reading, a held joint whose read-back jitters), and a
recorded check of an arm whose controller turns joints the other way, cut to
the least number of poses a check takes.
"""

from __future__ import annotations

import json

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_kit import cli

from calibrator import robots
from calibrator.check import circle as circles
from calibrator.verify import path_figures as ip


def test_a_bin_holding_one_reading_is_that_reading():
    width = np.radians(circles.BIN_DEG)
    angle = np.array([0.5 * width, 2.5 * width, 2.6 * width])
    dr = np.array([0.07, 0.01, 0.03])
    profile = circles.binned(angle, dr)
    assert profile[0] == pytest.approx(0.07)  # one reading: itself, not half of it
    assert profile[2] == pytest.approx(0.02)
    assert np.isnan(profile[1]) and np.isnan(profile[3:]).all()


def _run(q: np.ndarray) -> circles.Run:
    ccw = ip.circle([500.0, 0, 300], [0, 0, 1], 100.0, [1, 0, 0])
    t = np.linspace(0.0, 2 * np.pi, len(q))
    return circles.Run("counter-clockwise", ccw, t, q, ip.Stream(t, ccw.point(100.0 * t)))


def test_a_held_joint_whose_read_back_jitters_reverses_nowhere():
    n = 721
    q = np.zeros((n, 6))
    t = np.linspace(0.0, 2 * np.pi, n)
    q[:, 0] = -np.cos(t)  # turns, reverses at half a turn: the only mark
    q[:, 1] = 2.0 + 0.3 * t  # moves one way, high above the others
    q[:, 2] = 0.5 + 1e-7 * (-1.0) ** np.arange(n)  # held, sign of its steps flips on rounding
    run = _run(q)
    found = circles.joint_reversals(run.path, run)
    assert [j for j, _ in found] == [1]
    assert np.degrees(found[0][1]) == pytest.approx(180.0, abs=1.0)


@pytest.fixture
def measured_arm(tmp_path):
    """A UR10e measured on 12 poses and identified: the folder with its world and cal.json."""
    (tmp_path / "today.yaml").write_text("world: 1\nmodel: ur10e\nseed: 3\n")
    done = cli("measure", "--model", "ur10e", "--world", "today.yaml", "--poses", "12",
               "-o", "cal.parquet", "-q", cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    done = cli("identify", "cal.parquet", "-o", "cal.json", "-q", cwd=tmp_path)
    assert done.code == 0, done.stderr
    return tmp_path


def test_the_circle_section_says_what_was_run(measured_arm):
    done = cli("check", "--circle", "--calibration", "cal.json", "--world", "today.yaml",
               "--circle-speed", "80", "-o", "circle.json", cwd=measured_arm)  # fmt: skip
    assert done.code == 0, (done.stdout, done.stderr)
    doc = json.loads((measured_arm / "circle.json").read_text())
    section = doc["circle"]
    assert section["shape"] == "circle" and section["verdict"] == "ok"
    assert section["frame"] == "robot base (the model's)"
    assert section["speed_mm_s"] == 80.0 and section["compensated"] is True
    assert section["directions"] == ["clockwise", "counter-clockwise"]
    commanded = section["commanded"]
    assert commanded["length_mm"] == pytest.approx(2 * np.pi * commanded["radius_mm"])
    # The attained circle is the commanded one to within the limits (a sound arm).
    assert abs(section["radius_error_mm"]) < circles.LIMITS_MM["radius_error_mm"]
    assert section["marks"], "a circle of a 6-axis arm reverses some joint"
    for mark in section["marks"]:
        assert set(mark) >= {"direction", "joint", "angle_deg", "height_mm"}
        assert mark["height_mm"] is None or abs(mark["height_mm"]) < 0.05


def test_a_recorded_check_of_two_poses_states_the_controllers_joints(tmp_path):
    """KUKA's controller turns joints 1 and 6 the other way: the document shows its angles."""
    model = "kuka-kr6-r900"
    for name, poses in (("s", 24), ("again", 2)):  # one simulated arm and tracker (seed 3)
        done = cli("simulate", "--model", model, "--frame", "tracker", "--poses", str(poses),
                   "--seed", "3", "-o", f"{name}.parquet", cwd=tmp_path)  # fmt: skip
        assert done.code == 0, done.stderr
    done = cli("identify", "s.parquet", "-o", "cal.json", "-q", cwd=tmp_path)
    assert done.code == 0, done.stderr
    done = cli("check", "--calibration", "cal.json", "--session", "again.parquet",
               "-o", "check.json", cwd=tmp_path)  # fmt: skip
    assert done.code == 0, (done.stdout, done.stderr)
    doc = json.loads((tmp_path / "check.json").read_text())
    assert doc["verdict"] == "ok"
    assert doc["explanation_text"] == ["the arm measures as its calibration predicts"]
    # The session holds the controller's angles; the check computes with the model's.
    table = pq.read_table(tmp_path / "again.parquet").to_pandas()
    q_controller = table[[f"q{i}_rad" for i in range(1, 7)]].to_numpy()
    q_model = robots.convention_of(model).to_model(q_controller)
    np.testing.assert_allclose(q_model[:, [0, 5]], -q_controller[:, [0, 5]])
    shown = np.array([p["q_rad"] for p in doc["poses"]])
    assert len(shown) == 2
    np.testing.assert_allclose(shown, q_controller, atol=1e-12)
    for pose in doc["poses"]:
        error = np.subtract(pose["measured_mm"], pose["predicted_mm"])
        np.testing.assert_allclose(pose["error_mm"], error, atol=1e-9)
        assert pose["distance_mm"] == pytest.approx(np.linalg.norm(error))


def test_a_compliant_calibration_predicts_through_its_deflected_joints():
    """Compliance of joints 2 and 3 under a 5 kg payload: the check's model bends as identify's."""
    from calibrator.check.model import Calibrated
    from calibrator.model import joint_terms, parameters
    from calibrator.robots import masses

    arm = robots.get("ur10e")
    terms = joint_terms.JointTerms(
        np.zeros(6), np.zeros(6), np.zeros(6), np.array([0.0, 2e-6, 3e-6, 0.0, 0.0, 0.0]),
        payload_kg=5.0, payload_com_mm=np.array([0.0, 0.0, 100.0]), mass_model="ur10e",
    )  # fmt: skip
    space = parameters.ParameterSpace(arm.mdh)
    model = Calibrated(space, np.zeros((space.size, space.size)), 0.01, terms)
    q = np.random.default_rng(44).uniform(-1.5, 1.5, (5, 6))
    tau = joint_terms.gravity_torques(arm.mdh, q, masses.get("ur10e"), 5.0, [0.0, 0.0, 100.0])
    expected = joint_terms.effective(q, terms.vector(), tau)
    np.testing.assert_allclose(model.angles(q), expected, rtol=0, atol=1e-15)
    assert np.abs(expected - q)[:, 1:3].max() > 1e-5  # the joints do bend
