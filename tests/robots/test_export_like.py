"""``export-params --format urdf --like arm.urdf``: the user's URDF back, only its kinematics
calibrated."""

import subprocess
import sys

import numpy as np
import pytest
import yourdfpy
from robot_files_kit import KUKA, with_geometry

from calibrator import robots, simulate
from calibrator.calibration import Calibration
from calibrator.errors import CalibrationError
from calibrator.export import export_like
from calibrator.model import kinematics, parameters


def calibrated(path, seed=4):
    """A calibration of the URDF's arm with hidden MDH errors (Hayati betas included)."""
    arm = robots.get(str(path))
    rng = np.random.default_rng(seed)
    mdh = arm.mdh + simulate.random_errors(arm.mdh, rng, mm=0.5, rad=0.002)
    free = parameters.structural_candidates(arm.mdh, "base", True)[0]
    space = parameters.ParameterSpace(arm.mdh, free=tuple(free))
    return arm, Calibration(
        nominal_mdh=arm.mdh,
        mdh=mdh,
        base2tracker=np.eye(4),
        flange2tool=np.eye(4),
        model=arm.name,
        free=free,
        deltas=dict(zip(space.free, space.pack(mdh), strict=True)),
    )


def urdf_poses(text, tmp_path, q, tip="tool0"):
    path = tmp_path / "read.urdf"
    path.write_text(text)
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    out = []
    for row in q:
        model.update_cfg(dict(zip(model.actuated_joint_names, row, strict=True)))
        t = np.array(model.get_transform(tip, "base_link"))
        t[:3, 3] *= 1000.0
        out.append(t)
    return np.array(out)


@pytest.fixture
def user_urdf(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(with_geometry(KUKA))
    return path


def test_the_written_urdf_moves_as_the_calibration_does(user_urdf, tmp_path):
    arm, cal = calibrated(user_urdf)
    text = export_like(cal, user_urdf).text
    q = np.random.default_rng(7).uniform(-2.5, 2.5, (100, 6))  # URDF (controller) angles
    expected = arm.base_offset @ kinematics.chain(cal.mdh, arm.convention.to_model(q))
    expected = expected @ arm.flange_offset
    got = urdf_poses(text, tmp_path, q)
    assert np.abs(got[:, :3, 3] - expected[:, :3, 3]).max() < 1e-9
    assert np.abs(got[:, :3, :3] - expected[:, :3, :3]).max() < 1e-12
    # And it is not the nominal arm: the calibration changed something.
    assert (
        np.abs(got[:, :3, 3] - urdf_poses(user_urdf.read_text(), tmp_path, q)[:, :3, 3]).max() > 0.1
    )


def test_only_the_chains_joint_origins_change(user_urdf):
    _, cal = calibrated(user_urdf)
    before = user_urdf.read_text().splitlines()
    after = export_like(cal, user_urdf).text.splitlines()
    assert len(after) == len(before)
    changed = [i for i, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
    # Joints 2 to 6 and the flange's fixed joint: one origin line each. Joint 1
    # turns about the base's own axis, which a calibration in the base frame keeps:
    # its origin keeps its text too.
    assert len(changed) == 6
    joint_1 = next(i for i, line in enumerate(before) if 'name="joint_a1"' in line)
    assert before[joint_1 + 1].strip().startswith("<origin ") and joint_1 + 1 not in changed
    owners = [f"joint_a{k}" for k in range(2, 7)] + ["link_6-flange"]
    for i, owner in zip(changed, owners, strict=True):
        assert f'<joint name="{owner}"' in before[i - 1]
    for i in changed:
        assert before[i].strip().startswith("<origin ") and after[i].strip().startswith("<origin ")
        assert before[i].split("<origin")[0] == after[i].split("<origin")[0]  # indentation kept
    assert export_like(cal, user_urdf).text.endswith("</robot>\n")


def test_a_calibration_of_another_arm_is_refused(user_urdf, tmp_path):
    _, cal = calibrated(user_urdf)
    other = tmp_path / "other.urdf"
    other.write_text(KUKA.replace('xyz="0.455 0 0"', 'xyz="0.5 0 0"'))
    with pytest.raises(CalibrationError, match="not this URDF's chain"):
        export_like(cal, other)


def test_the_command_writes_the_users_urdf_and_refuses_overwriting_it(user_urdf, tmp_path):
    _, cal = calibrated(user_urdf)
    cal.save(tmp_path / "cal.json")
    out = tmp_path / "calibrated.urdf"
    run = [sys.executable, "-m", "calibrator", "export-params", str(tmp_path / "cal.json")]
    done = subprocess.run(
        [*run, "--format", "urdf", "--like", str(user_urdf), "-o", str(out)],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert out.read_text() == export_like(cal, user_urdf).text
    original = user_urdf.read_text()
    done = subprocess.run(
        [*run, "--format", "urdf", "--like", str(user_urdf), "-o", str(user_urdf)],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert user_urdf.read_text() == original


def test_a_urdf_arm_identified_and_written_back_moves_as_the_hidden_true_arm(user_urdf, tmp_path):
    from calibrator import session
    from calibrator.identify.pipeline import Options, identify
    from calibrator.simulate import simulate

    arm = robots.get(str(user_urdf))
    table, meta, truth = simulate(
        model=str(user_urdf), poses=40, noise_mm=0.02, errors="random", seed=8
    )
    session.write(tmp_path / "s.parquet", table, meta)
    result = identify(session.load(tmp_path / "s.parquet"), Options(seed=1))
    cal = Calibration.from_result(result, model=arm.name)
    written = export_like(cal, user_urdf).text
    # Held-out poses, read by an independent URDF reader.
    q = controller = np.random.default_rng(9).uniform(-1.5, 1.5, (200, 6))
    true = arm.base_offset @ kinematics.chain(truth.mdh, arm.convention.to_model(q))
    true = (true @ arm.flange_offset)[:, :3, 3]
    after = np.linalg.norm(urdf_poses(written, tmp_path, controller)[:, :3, 3] - true, axis=1)
    before = np.linalg.norm(urdf_poses(user_urdf.read_text(), tmp_path, q)[:, :3, 3] - true, axis=1)
    print(f"held-out mean: nominal {before.mean():.3f} mm, calibrated {after.mean():.4f} mm")
    assert before.mean() > 1.0  # mm: the nominal URDF is off
    assert after.mean() < 0.05  # the calibrated one is at the noise
