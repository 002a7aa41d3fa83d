"""A targets CSV as a FANUC controller states it: J1..J6 (J3 from the horizon), poses in World.

The M-20iA's World frame sits at J2 height, 525 mm above the model's base;
its J3 is measured from the horizon (the model's joint 3 is J3 + J2). A
CSV of targets taught on the pendant, joints and poses both, is corrected
for an identified arm: the corrected joints, sent to the true arm, land on
the taught pose, and the corrected pose is in World as the targets were.
"""

import numpy as np
import pandas as pd
import pytest
from cli_process_kit import run_cli

from calibrator import calibration, robots
from calibrator.model import frames, kinematics, rotations

ARM = "fanuc-m20ia"


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("fanuc")
    made = run_cli(
        "simulate", "--model", ARM, "--poses", "60", "--frame", "base", "--seed", "4",
        "-o", "s.parquet", cwd=tmp,
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    done = run_cli("identify", "s.parquet", "-q", "-o", "cal.json", cwd=tmp)
    assert done.returncode == 0, done.stderr
    return tmp


def test_taught_joints_and_world_poses_land_where_taught(cell):
    tmp = cell
    arm = robots.get(ARM)
    cal = calibration.load(tmp / "cal.json")
    world = arm.model_base2controller_base  # World in the model's base frame
    assert abs(world[2, 3] - 525.0) < 1e-6
    rng = np.random.default_rng(3)
    # Joints a pendant shows for a work cell in front of the arm.
    q_ctrl = np.column_stack(
        [
            rng.uniform(-0.6, 0.6, 20),
            rng.uniform(-0.3, 0.5, 20),
            rng.uniform(-0.5, 0.2, 20),
            rng.uniform(-1.0, 1.0, 20),
            rng.uniform(-1.4, -0.5, 20),
            rng.uniform(-2.0, 2.0, 20),
        ]
    )
    q_model = arm.convention.to_model(q_ctrl)
    # The pose the pendant shows at those joints: the TCP in World.
    taught = frames.invert(world) @ kinematics.chain(cal.nominal_mdh, q_model) @ cal.flange2tool
    columns = {f"q{i + 1}_rad": q_ctrl[:, i] for i in range(6)}
    columns.update({c: taught[:, k, 3] for k, c in enumerate(("x_mm", "y_mm", "z_mm"))})
    rotvec = rotations.matrix_to_rotvec(taught[:, :3, :3])
    columns.update({c: rotvec[:, k] for k, c in enumerate(("rx_rad", "ry_rad", "rz_rad"))})
    pd.DataFrame(columns).to_csv(tmp / "targets.csv", index=False)

    done = run_cli("compensate", "cal.json", "targets.csv", "-o", "out.csv", cwd=tmp)
    assert done.returncode == 0, done.stderr
    out = pd.read_csv(tmp / "out.csv")
    assert (out["status"] == "ok").all()
    q_out = out[[f"q{i}_rad" for i in range(1, 7)]].to_numpy()
    # The corrected joints are the controller's: close to the taught ones, not mirrored.
    assert np.max(np.abs(q_out - q_ctrl)) < 0.05
    # Sent to the calibrated (true-as-identified) arm, they land on the taught pose.
    landed = (
        frames.invert(world)
        @ kinematics.chain(cal.mdh, arm.convention.to_model(q_out))
        @ cal.flange2tool
    )
    np.testing.assert_allclose(landed[:, :3, 3], taught[:, :3, 3], atol=1e-4)
    # The corrected pose is in World: the nominal arm at the corrected joints.
    shown = out[["x_mm", "y_mm", "z_mm"]].to_numpy()
    nominal = (
        frames.invert(world)
        @ kinematics.chain(cal.nominal_mdh, arm.convention.to_model(q_out))
        @ cal.flange2tool
    )
    np.testing.assert_allclose(shown, nominal[:, :3, 3], atol=1e-4)


def test_targets_in_degrees_are_read_as_plan_files_give_them(cell):
    tmp = cell
    q = np.radians([[10.0, 20.0, -10.0, 30.0, -60.0, 45.0], [-20.0, 10.0, 5.0, -30.0, -70.0, 0.0]])
    pd.DataFrame({f"q{i + 1}_rad": q[:, i] for i in range(6)}).to_csv(tmp / "rad.csv", index=False)
    pd.DataFrame({f"q{i + 1}_deg": np.degrees(q[:, i]) for i in range(6)}).to_csv(
        tmp / "deg.csv", index=False
    )
    for name in ("rad", "deg"):
        done = run_cli("compensate", "cal.json", f"{name}.csv", "-o", f"{name}.out.csv", cwd=tmp)
        assert done.returncode == 0, done.stderr
    rad, deg = pd.read_csv(tmp / "rad.out.csv"), pd.read_csv(tmp / "deg.out.csv")
    np.testing.assert_allclose(
        deg.filter(like="_rad").to_numpy(), rad.filter(like="_rad").to_numpy(), atol=1e-9
    )
    both = pd.read_csv(tmp / "deg.csv").assign(q1_rad=0.0)
    both.to_csv(tmp / "both.csv", index=False)
    done = run_cli("compensate", "cal.json", "both.csv", "-o", "both.out.csv", cwd=tmp)
    assert done.returncode == 2 and "keep one" in done.stderr
