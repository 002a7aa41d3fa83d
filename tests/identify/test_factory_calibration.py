"""A factory calibration as the nominal model: which reader a file goes to, what
the imported table keeps, and what :func:`factory_calibration.apply` does to a session."""

from dataclasses import replace

import numpy as np
import pytest
import yaml
from export_kit import calibrated, poses, ur_file

from calibrator import export, robots
from calibrator.errors import CalibrationError
from calibrator.export import factory_calibration, ur
from calibrator.model import kinematics
from calibrator.session import SessionMeta


def ros_file(tmp_path, cal, name="kin.yaml", **changes):
    """The ROS kinematics YAML of ``cal``; ``changes``: ``joint=(key, value)``."""
    doc = yaml.safe_load(export.export(cal, "ros-kinematics").text)
    for joint, (key, value) in changes.items():
        doc["kinematics"][joint][key] = value
    path = tmp_path / name
    path.write_text(yaml.safe_dump(doc))
    return path


def same_chain(mdh, offset, want_mdh, n=40):
    q = poses(n, seed=8)
    got = kinematics.chain(mdh, q) @ offset
    want = kinematics.chain(want_mdh, q)
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, :3, :3], want[:, :3, :3], rtol=0, atol=1e-9)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(CalibrationError) as info:
        factory_calibration.load(tmp_path / "none.conf", model="ur10")
    assert str(info.value) == f"nominal file not found: {tmp_path / 'none.conf'}"


@pytest.mark.parametrize("name", ["kin.yml", "KIN.YML", "kin.Yaml"])
def test_yaml_and_yml_files_are_ros_kinematics(tmp_path, name):
    cal = calibrated("ur10e", seed=41, trailing=False)
    imported = factory_calibration.load(ros_file(tmp_path, cal, name), model="ur10e")
    assert imported.source == "ros-kinematics" and imported.model == "ur10e"
    np.testing.assert_allclose(imported.mdh, cal.mdh, atol=1e-9)


def test_ur_deltas_without_a_model_take_the_callers(tmp_path):
    cal = calibrated("ur10", seed=42, trailing=False)
    deltas, _ = ur.deltas_from_mdh(cal.mdh, "ur10")
    values = {
        "delta_theta": deltas[:, kinematics.THETA].tolist(),
        "delta_a": (deltas[:, kinematics.A] / 1000.0).tolist(),
        "delta_d": (deltas[:, kinematics.D] / 1000.0).tolist(),
        "delta_alpha": deltas[:, kinematics.ALPHA].tolist(),
    }
    path = ur_file(tmp_path, values, model=None)
    imported = factory_calibration.load(path, model="ur10")
    assert imported.source == "ur-calibration" and imported.model == "ur10"
    np.testing.assert_array_equal(imported.base2frame0, np.eye(4))
    same_chain(imported.mdh, imported.flange_offset, cal.mdh)
    # A reference table with d2 elsewhere: the table keeps it, same arm.
    reference = robots.get("ur10").mdh.copy()
    reference[1, kinematics.D] = -25.0
    moved = factory_calibration.load(path, reference=reference, model="ur10")
    assert moved.mdh[1, kinematics.D] == pytest.approx(-25.0, abs=1e-9)
    same_chain(moved.mdh, moved.flange_offset, cal.mdh)


def test_a_calibrated_reference_keeps_its_hayati_structure(tmp_path):
    """A previous calibration as reference (axes 2-3-4 parallel only to within a
    few mrad): the import still uses beta there, not the common normal of
    nearly parallel axes hundreds of metres away."""
    reference = calibrated("ur10e", seed=43, trailing=False).mdh
    arm = calibrated("ur10e", seed=44, trailing=False).mdh
    cal = replace(calibrated("ur10e"), mdh=arm)
    imported = factory_calibration.load(ros_file(tmp_path, cal), reference=reference, model="ur10e")
    np.testing.assert_allclose(
        imported.mdh[1:3, kinematics.D], reference[1:3, kinematics.D], atol=1e-9
    )
    assert np.all(np.abs(imported.mdh - reference) < 5.0)
    same_chain(imported.mdh, imported.flange_offset, arm)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the inf on purpose
def test_a_file_that_is_not_a_6r_arm_is_refused(tmp_path):
    cal = calibrated("ur10e", seed=45, trailing=False)
    path = ros_file(tmp_path, cal, wrist_2=("x", 1e306))  # finite in the file, inf in mm
    with pytest.raises(CalibrationError) as info:
        factory_calibration.load(path, model="ur10e")
    assert str(info.value) == f"{path}: the kinematics do not describe a 6R arm"


def meta(frame="base", model="ur10e"):
    tool = np.eye(4)
    tool[:3, 3] = [1.0, 2.0, 150.0]
    return SessionMeta(frame, robots.get("ur10e").mdh, model, tool)


def test_apply_makes_the_file_the_sessions_nominal(tmp_path):
    cal = calibrated("ur10e", seed=46, trailing=False)
    path = ros_file(tmp_path, cal)
    given = meta()
    m, line = factory_calibration.apply(given, path)
    assert line == f"nominal model from {path} (ros-kinematics against ur10e)"
    np.testing.assert_allclose(m.nominal_mdh, cal.mdh, atol=1e-9)
    np.testing.assert_allclose(m.flange2tool, given.flange2tool, atol=1e-9)
    # The footer given is not changed: the imported table is in the one returned.
    np.testing.assert_array_equal(given.nominal_mdh, robots.get("ur10e").mdh)
    assert (m.frame, m.model, m.tool_known) == (given.frame, given.model, given.tool_known)
    unnamed, line = factory_calibration.apply(meta(model=None), path)
    assert line == f"nominal model from {path} (ros-kinematics)"
    np.testing.assert_allclose(unnamed.nominal_mdh, cal.mdh, atol=1e-9)


@pytest.mark.parametrize(("shift_m", "refused"), [(0.01, True), (2e-9, True), (1e-10, False)])
def test_apply_refuses_a_moved_joint_1_axis_for_a_base_frame_session(tmp_path, shift_m, refused):
    cal = calibrated("ur10e", seed=47, trailing=False)
    path = ros_file(tmp_path, cal, shoulder=("x", shift_m))
    m = meta("base")
    before = m.nominal_mdh.copy()
    if refused:
        with pytest.raises(CalibrationError) as info:
            factory_calibration.apply(m, path)
        mm = shift_m * 1000.0
        assert str(info.value) == (
            f"{path} moves joint 1's axis by {mm:.3g} mm, 0 rad from its base frame; "
            "a session in the base frame cannot take it (measure in the tracker frame)"
        )
        np.testing.assert_array_equal(m.nominal_mdh, before)
    else:
        applied, _ = factory_calibration.apply(m, path)
        np.testing.assert_allclose(applied.nominal_mdh, cal.mdh, atol=1e-6)
    # In the tracker frame, base2tracker absorbs where joint 1 is.
    t, _ = factory_calibration.apply(meta("tracker"), path)
    np.testing.assert_allclose(t.nominal_mdh, cal.mdh, atol=1e-6)


def test_apply_refuses_a_tilted_joint_1_axis_for_a_base_frame_session(tmp_path):
    cal = calibrated("ur10e", seed=48, trailing=False)
    path = ros_file(tmp_path, cal, shoulder=("roll", 1e-6))
    with pytest.raises(CalibrationError, match=r" mm, 1e-06 rad from its base frame"):
        factory_calibration.apply(meta("base"), path)


def test_apply_refuses_a_joint_1_axis_tilted_about_the_base_origin(tmp_path):
    """Axis 1 through the base origin but tilted by 1 urad: nothing moves at the
    origin, the direction alone is refused."""
    cal = calibrated("ur10e", seed=49, trailing=False)
    d1 = float(cal.mdh[0, kinematics.D]) / 1000.0
    doc = yaml.safe_load(export.export(cal, "ros-kinematics").text)
    kin = doc["kinematics"]
    assert kin["shoulder"]["z"] == pytest.approx(d1)
    kin["shoulder"].update(z=0.0, roll=1e-6)
    kin["upper_arm"]["z"] += d1  # d1 now along the tilted axis, after joint 1
    path = tmp_path / "kin.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(CalibrationError) as info:
        factory_calibration.apply(meta("base"), path)
    assert f"{path} moves joint 1's axis by 0 mm, 1e-06 rad from its base frame" in str(info.value)
