"""The driver against the simulator over a real pty and over socket://127.0.0.1.

Readings must carry the configured anisotropic noise: unbiased, about 2x
smaller along the beam than across it at 1 m and growing with range.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from tracker_kit import REPO, live_tracker

from drivers.tracker import (
    BeamBroken,
    NotInitialised,
    TrackerError,
    TrackerTimeout,
    measure_average,
)
from drivers.tracker.instrument import beam_frame
from drivers.tracker.line.simulator import (
    NoiseModel,
    SimulatorProcess,
    SimulatorServer,
    TrackerSimulator,
)

TARGET = np.array([3000.0, 1000.0, 500.0])  # ~3.2 m from the tracker
N_READINGS = 600


def check_noise_statistics(points: np.ndarray, target: np.ndarray) -> None:
    """Mean within 4 standard errors of the truth; per-axis sigma within 12 % of the model."""
    along_sigma, trans_sigma = NoiseModel().sigmas_mm(target)
    dev = (points - target) @ np.array(beam_frame(target)).T  # columns: along, side1, side2
    n = len(points)
    sigmas = np.array([along_sigma, trans_sigma, trans_sigma])
    assert np.all(np.abs(dev.mean(axis=0)) < 4 * sigmas / np.sqrt(n)), dev.mean(axis=0)
    # The relative standard error of a sample sigma is 1/sqrt(2n) ~ 3 %; 12 % is 4 of those.
    np.testing.assert_allclose(dev.std(axis=0, ddof=1), sigmas, rtol=0.12)


@pytest.mark.parametrize("transport", ["pty", "tcp"])
def test_noise_statistics_through_the_wire(sim_process, transport):
    _, (path, port) = sim_process(
        "--pty", "--tcp", "0", "--seed", "3", "--initialised", "--target", "3000,1000,500"
    )
    url = path if transport == "pty" else f"socket://127.0.0.1:{port}"
    with live_tracker(url) as tracker:
        status = tracker.connect()
        identity = tracker.identity
        assert identity.model == "TRACKER-SIM" and status.state == "READY"
        readings = [tracker.measure() for _ in range(N_READINGS)]
    assert all(r.accurate for r in readings)
    check_noise_statistics(np.array([r.point_mm for r in readings]), TARGET)


def test_noise_grows_across_the_beam_with_range(served):
    sim, path, _ = served
    spreads = []
    with live_tracker(path) as tracker:
        tracker.connect()
        for range_mm in (2000.0, 20000.0):
            sim.set_target([0.0, range_mm, 0.0])  # beam along y
            pts = np.array([tracker.measure().point_mm for _ in range(300)])
            spreads.append(pts.std(axis=0, ddof=1))
    near, far = spreads
    # Along the beam (y) barely changes; across it (x, z) grows with 6 um/m.
    assert far[1] < 1.5 * near[1]
    assert far[0] > 2.5 * near[0] and far[2] > 2.5 * near[2]
    assert near[0] > 1.5 * near[1]  # anisotropic already at 2 m


def test_same_seed_same_readings():
    def run(seed):
        sim = TrackerSimulator(seed=seed, initialised=True)
        sim.set_target(TARGET)
        with SimulatorServer(sim) as server:
            path = server.open_pty()
            server.start()
            with live_tracker(path) as tracker:
                tracker.connect()
                return np.array([tracker.measure().point_mm for _ in range(20)])

    np.testing.assert_array_equal(run(4), run(4))
    assert not np.array_equal(run(4), run(5))


def test_6dof_probe_orientation(sim_process):
    _, (path,) = sim_process(
        "--pty", "--probe-6dof", "--initialised", "--target", "2500,0,400,0.1,-0.2,0.3"
    )
    with live_tracker(path) as tracker:
        status = tracker.connect()
        assert status.probe_6dof
        avg = measure_average(tracker, n=50)
    np.testing.assert_allclose(avg.rotvec_mean_rad, [0.1, -0.2, 0.3], atol=3e-5)
    sigma = NoiseModel().rotation_mpe_rad / 2
    assert np.all((avg.rotvec_std_rad > 0.6 * sigma) & (avg.rotvec_std_rad < 1.5 * sigma))
    np.testing.assert_allclose(avg.mean_mm, [2500, 0, 400], atol=0.01)


def test_init_required_then_initialise(sim_process):
    _, (path,) = sim_process("--pty", "--init-time", "0.3", "--target", "2000,0,0")
    with live_tracker(path) as tracker:
        status = tracker.connect()
        assert not status.initialised and status.state == "NOT_READY"
        with pytest.raises(NotInitialised):
            tracker.measure()
        tracker.initialise()
        assert tracker.status().state == "READY"
        assert np.linalg.norm(tracker.measure().point_mm - [2000, 0, 0]) < 0.1


def test_a_time_scaled_simulator_stamps_its_readings_that_much_faster(sim_process):
    """``--time-scale 10``: 0.2 s of the wall clock between two readings is 2 s of its clock."""
    import time

    _, (path,) = sim_process("--pty", "--initialised", "--target", "2000,0,0", "--time-scale", "10")
    with live_tracker(path) as tracker:
        tracker.connect()
        first = tracker.measure().device_time_us
        start = time.monotonic()
        time.sleep(0.2)
        second = tracker.measure().device_time_us
        wall_us = (time.monotonic() - start) * 1e6
    assert 9.0 * 0.2e6 <= second - first <= 10.0 * wall_us + 1e5


@pytest.mark.parametrize("scale", ["0", "1e9", "fast"])
def test_a_time_scale_out_of_its_range_is_one_line_exit_2(scale):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "drivers.tracker.line.simulator",
            "--tcp",
            "0",
            "--time-scale",
            scale,
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.strip().endswith(f"expected a time scale in 0.01..100, got {scale!r}")


def test_target_set_over_the_wire_from_a_second_connection(sim_process):
    """A simulated robot moves the target over TCP; the driver sees it on the pty."""
    _, (path, port) = sim_process("--pty", "--tcp", "0", "--initialised", "--no-noise")
    with live_tracker(path) as tracker, live_tracker(f"socket://127.0.0.1:{port}") as robot_side:
        tracker.connect()
        robot_side.connect()
        with pytest.raises(BeamBroken):  # no target yet
            tracker.measure()
        for target in ([1500.0, -20.0, 35.5], [-2200.0, 800.25, 10.0]):
            robot_side.send("SIM", "TARGET", *(f"{v}" for v in target))
            np.testing.assert_array_equal(tracker.measure().point_mm, target)
        robot_side.send("SIM", "NOTARGET")
        with pytest.raises(BeamBroken):
            tracker.measure()


def test_out_of_range_target_is_refused(served):
    sim, path, _ = served
    sim.set_target([100.0, 0.0, 0.0])
    with live_tracker(path) as tracker:
        tracker.connect()
        with pytest.raises(TrackerError, match="OUT_OF_RANGE"):
            tracker.measure()


def test_simulator_imports_only_the_port_contract_and_the_simulated_world():
    # The simulated device knows the port contract its driver's errors derive
    # from and the one simulated world (its noise model), nothing else of the
    # product's domain: no solver, session, plan or command line, and no scipy.
    # The arm descriptions the simulated world is built from (calibrator.robots: its
    # description files are read through the strict reader and converted by
    # calibrator.model.conventions).
    allowed = {
        "calibrator", "calibrator.acquire", "calibrator.acquire.ports", "calibrator.simulate",
        "calibrator.errors", "calibrator.model", "calibrator.model.frames",
        "calibrator.model.kinematics", "calibrator.model.parameters", "calibrator.model.distance",
        "calibrator.model.noise", "calibrator.model.rotations",
        "calibrator.model.joint_terms", "calibrator.model.mass_models",
        "calibrator.robots", "calibrator.robots.description", "calibrator.robots.files",
        "calibrator.robots.ipso_paper", "calibrator.robots.urdf", "calibrator.robots.ur",
        "calibrator.robots.enclosing", "calibrator.robots.shipped", "calibrator.model.conventions",
        "calibrator.robots.clearance", "calibrator.inputs",
        "calibrator.inputs.errors", "calibrator.inputs.grammar", "calibrator.inputs.messages",
        "calibrator.inputs.textfile", "calibrator.inputs.yamlfile", "calibrator.inputs.rules",
        "calibrator.inputs.budgets",
    }  # fmt: skip
    code = (
        "import sys, drivers.tracker.line.simulator.__main__ as m; "
        "mods = {n for n in sys.modules if n.split('.')[0] == 'calibrator'}; "
        # The URDF reader is a package: its modules come with it.
        f"extra = {{n for n in mods - {allowed!r} "
        "if not n.startswith('calibrator.robots.urdf.')}; "
        "assert not extra, f'calibrator imported: {sorted(extra)}'; "
        "assert 'scipy' not in sys.modules, 'scipy imported'; print('ok')"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=30
    )
    assert out.stdout.strip() == "ok", out.stderr


def test_command_line_needs_an_endpoint():
    out = subprocess.run(
        [sys.executable, "-m", "drivers.tracker.line.simulator"],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert out.returncode == 2 and "--pty" in out.stderr


def test_fault_script_file_and_wire_armed_fault(sim_process, tmp_path):
    script = tmp_path / "faults.txt"
    script.write_text("# second reading is lost\nMEAS@2 drop\n")
    _, (port,) = sim_process(
        "--tcp", "0", "--initialised", "--target", "2000,0,0", "--faults", str(script)
    )
    with live_tracker(f"socket://127.0.0.1:{port}") as tracker:
        tracker.connect()
        assert tracker.measure().accurate
        with pytest.raises(TrackerTimeout):
            tracker.measure(timeout_s=0.2)
        tracker.send("SIM", "FAULT", "MEAS+1 error code=NOT_WARMED_UP")
        with pytest.raises(TrackerError, match="NOT_WARMED_UP"):
            tracker.measure()
        with pytest.raises(TrackerError, match="BAD_PARAMETER"):
            tracker.send("SIM", "FAULT", "MEAS+1 explode")
        assert tracker.measure().accurate


def test_simulator_process_entry_point_steers_the_target():
    with SimulatorProcess(seed=2, noise=False, initialised=True) as sim:
        with live_tracker(sim.url) as tracker:
            tracker.connect()
            sim.set_target([1500.123456, -250.5, 80.25])
            np.testing.assert_array_equal(tracker.measure().point_mm, [1500.1235, -250.5, 80.25])
            sim.arm_fault("MEAS+1 beam_break")
            with pytest.raises(BeamBroken):
                tracker.measure()
            assert tracker.measure().accurate  # count=1: the beam re-locks by itself
            sim.clear_target()
            with pytest.raises(BeamBroken):
                tracker.measure()
