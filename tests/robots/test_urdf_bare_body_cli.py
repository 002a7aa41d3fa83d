"""``calibrator plan`` for a URDF without collision geometry whose joint 1 sits on the plane.

In a new process; the body itself is tested in process in test_urdf_bare_body.py.
"""

from cli_process_kit import run_cli
from robot_files_kit import DATA, joint_1_on_the_plane


def test_a_plan_for_an_arm_whose_joint_1_is_on_the_plane_finds_its_poses(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(joint_1_on_the_plane((DATA / "abb-irb4600-60-205.urdf").read_text()))
    done = run_cli(
        "plan", "--model", "arm.urdf", "--tracker-at", "0,-3000,800", "--poses", "12",
        "--seed", "1", "-o", "plan.csv", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "wrote plan.csv: 12 poses" in done.stdout
