"""Adding an arm is one new description module: the made-up arm below is planned,
identified and exported with nothing else changed."""

import sys
import textwrap

import numpy as np
import pytest

from calibrator import cell, export, planning, robots, session
from calibrator.calibration import Calibration
from calibrator.identify.pipeline import Options, identify
from calibrator.robots import masses as robot_masses
from calibrator.simulate import simulate

TOOL_MM = (0.0, 0.0, 100.0)

MADE_UP = textwrap.dedent(
    '''
    """A made-up 6R arm: one module, nothing else."""
    import numpy as np

    from calibrator.robots import Body, Capsule, RobotDescription

    def _describe():
        deg = np.pi / 180
        mdh = np.zeros((6, 5))
        mdh[:, 0] = [150, 600, 120, 0, 0, 0]
        mdh[:, 1] = np.array([-90, 0, -90, 90, -90, 0]) * deg
        mdh[:, 2] = np.array([0, -90, 0, 0, 0, 0]) * deg
        mdh[:, 3] = [450, 0, 0, 640, 0, 100]
        caps = (
            Capsule("turret", 1, (-150.0, 0.0, 0.0), (0.0, 0.0, 0.0), 110.0),
            Capsule("upper arm", 2, (-600.0, 0.0, 0.0), (0.0, 0.0, 0.0), 90.0),
            Capsule("elbow", 3, (-120.0, 0.0, 0.0), (0.0, 0.0, 0.0), 90.0),
            Capsule("forearm", 3, (0.0, 0.0, 0.0), (0.0, 0.0, 560.0), 70.0),
            Capsule("wrist", 5, (0.0, 0.0, -60.0), (0.0, 0.0, 100.0), 60.0),
        )
        return RobotDescription(
            name="madeup-6",
            mdh=mdh,
            joint_limits_rad=np.tile([-np.pi, np.pi], (6, 1)),
            max_joint_speed_rad_s=np.full(6, 3.0),
            max_joint_accel_rad_s2=np.full(6, 1.5),
            body=Body(caps, 120.0, 320.0, 0.0, (0.0, 0.0, 450.0)),
            configurations={"home": (0.0,) * 6, "upright": (0, 0, -np.pi / 2, 0, 0, 0)},
            mass_kg=np.array([20.0, 15.0, 8.0, 3.0, 2.0, 0.5]),
            com_mm=np.zeros((6, 3)),
            source="made up for a test",
        )

    DESCRIPTIONS = {"madeup-6": _describe}
    '''
)


@pytest.fixture
def made_up_arm(tmp_path, monkeypatch):
    """The package's modules plus one more, in a directory of its own."""
    (tmp_path / "madeup.py").write_text(MADE_UP)
    monkeypatch.setattr(robots, "__path__", [*robots.__path__, str(tmp_path)])
    yield robots.get("madeup-6")
    sys.modules.pop("calibrator.robots.madeup", None)


def test_a_new_module_is_a_new_named_arm_with_its_data(made_up_arm):
    from calibrator import robots

    assert "madeup-6" in robots.names()
    assert made_up_arm.move_accel_cap_rad_s2 == 1.5  # its own, lower than the fixed 2.0
    assert made_up_arm.move_speed_cap_rad_s == 1.0
    assert robot_masses.get("madeup-6").mass_kg[0] == 20.0
    assert made_up_arm.digest.startswith("sha256:") and len(made_up_arm.digest) == 71


def test_a_new_arm_is_planned_identified_and_exported(made_up_arm, tmp_path):
    where = cell.Cell(tracker_at_mm=(2500.0, 400.0, 300.0))
    made = planning.make_checked(made_up_arm, 30, where, TOOL_MM, seed=2)
    planning.check_plan(made.plan, made_up_arm, where, TOOL_MM)
    geometry = cell.arm_geometry("madeup-6", made_up_arm.mdh, TOOL_MM)
    assert geometry.upright_rad == (0.0, -np.pi / 2)
    assert geometry.base_radius_mm == 120.0

    table, meta, truth = simulate(model="madeup-6", poses=40, noise_mm=0.0, errors="random", seed=5)
    session.write(tmp_path / "s.parquet", table, meta)
    loaded = session.load(tmp_path / "s.parquet")
    assert loaded.meta.model == "madeup-6"
    result = identify(loaded, Options(seed=1))
    after = result.stats["validation"]["after"]["position_mm"]["mean"]
    before = result.stats["validation"]["before"]["position_mm"]["mean"]
    assert after < 1e-3 < before

    cal = Calibration.from_result(result, model="madeup-6")
    text = export.export(cal, "urdf").text
    assert 'name="madeup-6_calibrated"' in text
    # Its own limits go into the URDF, not a UR's.
    assert f'velocity="{3.0!r}"' in text
    with pytest.raises(Exception, match="needs a UR model"):
        export.export(cal, "ur-calibration")
