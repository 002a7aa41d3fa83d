"""Every export format, read back by an independent reader, gives the calibrated arm."""

import json
from dataclasses import replace

import export_kit as kit
import numpy as np
import pandas as pd
import pytest
import yaml
import yourdfpy
from cli_process_kit import run_cli  # the CLI as a user runs it: a real process

from calibrator import export, robots, simulate
from calibrator.calibration import Calibration
from calibrator.errors import CalibrationError
from calibrator.export import ur
from calibrator.model import frames, kinematics, rotations


def calibrated(a6_alpha6=False, seed=4):
    """A UR10e with hidden MDH errors (Hayati betas included), a tool and a base."""
    return kit.calibrated("ur10e", seed=seed, trailing=a6_alpha6)


def poses(n=200, seed=1):
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, 6))


def origin(xyz, rpy):
    """URDF origin: Trans(xyz) . Rz(yaw) Ry(pitch) Rx(roll), written out."""
    r, p, y = rpy
    rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    t = np.eye(4)
    t[:3, :3] = rz @ ry @ rx
    t[:3, 3] = xyz
    return t


def yaml_fk(doc, q):
    """Forward kinematics (m) of a ur_description kinematics file, joint by joint."""
    out = []
    for row in q:
        t = np.eye(4)
        for i, name in enumerate(
            ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
        ):
            j = doc["kinematics"][name]
            t = t @ origin([j["x"], j["y"], j["z"]], [j["roll"], j["pitch"], j["yaw"]])
            t = t @ origin([0, 0, 0], [0, 0, row[i]])
        out.append(t)
    return np.array(out)


@pytest.mark.parametrize("a6_alpha6", [False, True])
def test_ros_kinematics_round_trip(a6_alpha6):
    cal = calibrated(a6_alpha6)
    result = export.export(cal, "ros-kinematics")
    doc = yaml.safe_load(result.text)
    assert doc["kinematics"]["hash"].startswith("calib_")
    q = poses()
    got = yaml_fk(doc, q)
    want = kinematics.chain(cal.mdh, q)
    if a6_alpha6:
        # The file cannot hold a6/alpha6: the export says so, with the residual.
        assert len(result.notes) == 1 and "cannot hold a6, alpha6" in result.notes[0]

        trailing = kinematics.joint_origins(cal.mdh)[1]
        got[:, :3, 3] *= 1000.0
        got = got @ trailing
        got[:, :3, 3] /= 1000.0
    else:
        assert result.notes == []
    np.testing.assert_allclose(got[:, :3, 3] * 1000.0, want[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, :3, :3], want[:, :3, :3], rtol=0, atol=1e-9)


def test_urdf_round_trip_through_yourdfpy(tmp_path):
    cal = calibrated(a6_alpha6=True)
    result = export.export(cal, "urdf")
    assert result.notes == []
    path = tmp_path / "arm.urdf"
    path.write_text(result.text)
    robot = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    joints = robot.actuated_joint_names
    assert len(joints) == 6
    q = poses(50)
    want = kinematics.chain(cal.mdh, q) @ cal.flange2tool
    for row, pose in zip(q, want, strict=True):
        robot.update_cfg(dict(zip(joints, row, strict=True)))
        got = robot.get_transform("tool", "base_link")
        np.testing.assert_allclose(got[:3, 3] * 1000.0, pose[:3, 3], rtol=0, atol=1e-6)
        np.testing.assert_allclose(got[:3, :3], pose[:3, :3], rtol=0, atol=1e-9)


def test_ur_calibration_round_trip():
    cal = calibrated(a6_alpha6=True)
    result = export.export(cal, "ur-calibration")
    assert result.notes == []
    assert "[mounting]" in result.text and "model = ur10e" in result.text


def test_ur_calibration_converts_back(tmp_path):
    cal = calibrated(a6_alpha6=True)
    path = tmp_path / "ur.conf"
    path.write_text(export.export(cal, "ur-calibration").text)
    deltas, model = ur.read(path)
    mdh, residual = ur.mdh_from_deltas(deltas, model)
    q = poses()
    got = kinematics.chain(mdh, q) @ residual
    want = kinematics.chain(cal.mdh, q)
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)
    np.testing.assert_allclose(got[:, :3, :3], want[:, :3, :3], rtol=0, atol=1e-9)
    # UR's form is standard DH: nearly parallel axes 2-3 give a large d.
    dh = robots.get("ur10e").mdh + deltas
    assert abs(dh[1, kinematics.D]) > 1000.0


def test_ur_calibration_needs_a_ur_model():
    cal = replace(calibrated(), model=None)
    with pytest.raises(CalibrationError, match="needs a UR model"):
        export.export(cal, "ur-calibration")


def test_json_and_csv_hold_the_whole_model():
    cal = calibrated(a6_alpha6=True)
    doc = json.loads(export.export(cal, "json").text)
    mdh = np.array([[j[f] for f in kinematics.FIELDS] for j in doc["joints"]])
    np.testing.assert_array_equal(mdh, cal.mdh)
    np.testing.assert_array_equal(doc["flange2tool"], cal.flange2tool)
    assert doc["joints"][1]["free"]["beta_rad"] and not doc["joints"][1]["free"]["d_mm"]
    assert doc["free_frames"] == {"base2tracker": [], "flange2tool": ["tool_x"]}

    from io import StringIO

    table = pd.read_csv(StringIO(export.export(cal, "csv").text))
    pivot = table.pivot(index="element", columns="parameter", values="identified")
    mdh = pivot.loc[[f"joint{j}" for j in range(1, 7)], list(kinematics.FIELDS)].to_numpy()
    np.testing.assert_array_equal(mdh, cal.mdh)
    for element in ("base2tracker", "flange2tool"):
        v = pivot.loc[element, ["x_mm", "y_mm", "z_mm", "rx_rad", "ry_rad", "rz_rad"]].to_numpy(
            float
        )
        rebuilt = frames.transform(rotations.rotations_xyz(v[3:]), v[:3])
        np.testing.assert_allclose(rebuilt, getattr(cal, element), atol=1e-12)
    free = table.set_index(["element", "parameter"])["free"]
    assert free[("joint2", "beta_rad")] == 1 and free[("joint2", "d_mm")] == 0
    assert free[("flange2tool", "x_mm")] == 1 and free[("base2tracker", "x_mm")] == 0
    nominal = table.set_index(["element", "parameter"])["nominal"]
    assert nominal[("joint1", "d_mm")] == robots.get("ur10e").mdh[0, kinematics.D]


def test_format_choice():
    assert export.choose(None, "out.urdf") == "urdf"
    assert export.choose(None, "kin.yaml") == "ros-kinematics"
    assert export.choose(None, None) == "json"
    assert export.choose("csv", "p.csv") == "csv"
    with pytest.raises(CalibrationError, match="does not end in .json"):
        export.choose("json", "out.xml")
    with pytest.raises(CalibrationError, match="cannot tell the format"):
        export.choose(None, "out.xml")


def test_cli_export_formats(tmp_path):
    calibrated().save(tmp_path / "cal.json")
    out = run_cli("export-params", "cal.json", "-o", "arm.urdf", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert "(urdf)" in out.stdout and (tmp_path / "arm.urdf").read_text().startswith("<?xml")
    bad = run_cli("export-params", "cal.json", "--format", "json", "-o", "out.xml", cwd=tmp_path)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "out.xml" in bad.stderr
    assert not (tmp_path / "out.xml").exists()
    noted = run_cli("export-params", "cal.json", "-o", "k.yaml", cwd=tmp_path)
    assert noted.returncode == 0 and noted.stderr == ""
    same = run_cli("export-params", "cal.json", "-o", "cal.json", cwd=tmp_path)
    assert same.returncode == 2 and "overwrite" in same.stderr


def test_ros_kinematics_imports_as_nominal(tmp_path):
    from calibrator.export import factory_calibration

    cal = calibrated(a6_alpha6=False)
    path = tmp_path / "kin.yaml"
    path.write_text(export.export(cal, "ros-kinematics").text)
    imported = factory_calibration.load(path, model="ur10e")
    assert imported.source == "ros-kinematics"
    q = poses()
    got = kinematics.chain(imported.mdh, q) @ imported.flange_offset
    want = kinematics.chain(cal.mdh, q)
    np.testing.assert_allclose(got[:, :3, 3], want[:, :3, 3], rtol=0, atol=1e-6)
    # Same Hayati structure as the catalogue table: d2, d3 stay 0, betas carry the tilt.
    np.testing.assert_allclose(imported.mdh, cal.mdh, atol=1e-9)


def test_identify_with_factory_nominal(tmp_path):
    """A session of an arm whose only errors are a factory calibration: with that
    calibration as the nominal, nothing is left to identify."""
    from calibrator import session

    rng = np.random.default_rng(7)
    nominal_mdh = robots.get("ur10e").mdh
    factory = nominal_mdh + simulate.random_errors(nominal_mdh, rng, mm=0.5, rad=0.002)
    factory[5, [kinematics.A, kinematics.ALPHA]] = 0.0
    conf = Calibration(nominal_mdh=factory, mdh=factory, model="ur10e")
    (tmp_path / "factory.conf").write_text(export.export(conf, "ur-calibration").text)
    q = rng.uniform(-np.pi, np.pi, (40, 6))
    tool = frames.transform(None, [0.0, 0.0, 100.0])
    pose = kinematics.chain(factory, q) @ tool
    table = session.to_table(q, pose[:, :3, 3], rotations.matrix_to_rotvec(pose[:, :3, :3]))
    meta = session.SessionMeta("base", nominal_mdh, "ur10e", tool, tool_known=True)
    session.write(tmp_path / "s.parquet", table, meta)
    out = run_cli(
        "identify",
        "s.parquet",
        "--method",
        "lm",
        "--nominal",
        "factory.conf",
        "-o",
        "c.json",
        cwd=tmp_path,
    )
    assert out.returncode == 0, out.stderr
    assert "nominal model from factory.conf (ur-calibration against ur10e)" in out.stdout
    doc = json.loads((tmp_path / "c.json").read_text())
    np.testing.assert_allclose(doc["nominal_mdh"], factory, atol=1e-9)
    assert doc["stats"]["fit"]["before"]["position_mm"]["max"] < 1e-6


@pytest.mark.parametrize("model", ["ur5e", "ur10e", "ur10"])
def test_ur_published_kinematics_yaml(model):
    """UR's own files: our catalogue table, our import and our export agree with them."""
    from pathlib import Path

    from calibrator.export import factory_calibration

    path = Path(__file__).parents[2] / "fixtures" / "ur" / "description"
    path = path / f"{model}_default_kinematics.yaml"
    q = poses()
    theirs = yaml_fk(yaml.safe_load(path.read_text()), q)
    catalogue = robots.get(model).mdh
    np.testing.assert_allclose(
        kinematics.chain(catalogue, q)[:, :3, 3], theirs[:, :3, 3] * 1000.0, rtol=0, atol=1e-6
    )
    imported = factory_calibration.load(path, model=model)
    np.testing.assert_allclose(imported.mdh, catalogue, atol=1e-9)
    ours = Calibration(nominal_mdh=catalogue, mdh=catalogue, model=model)
    exported = yaml_fk(yaml.safe_load(export.export(ours, "ros-kinematics").text), q)
    np.testing.assert_allclose(exported[:, :3, 3], theirs[:, :3, 3], rtol=0, atol=1e-9)
    np.testing.assert_allclose(exported[:, :3, :3], theirs[:, :3, :3], rtol=0, atol=1e-9)
