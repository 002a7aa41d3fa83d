"""The command line with a user's arm: a 7-axis URDF refused in one line, its input never written.

In new processes (``python -m calibrator``), apart from the in-process tests
of test_user_files.py, which measure the descriptions themselves.
"""

import subprocess
import sys

from robot_files_kit import KUKA, seven_axes


def test_the_command_line_refuses_a_seven_axis_urdf_with_one_line(tmp_path):
    (tmp_path / "arm.urdf").write_text(seven_axes(KUKA))
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "calibrator",
            "plan",
            "--model",
            str(tmp_path / "arm.urdf"),
            "-o",
            str(tmp_path / "plan.csv"),
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert done.returncode == 2
    assert len(done.stderr.strip().splitlines()) == 1
    assert "only serial 6-axis arms are supported" in done.stderr
    assert not (tmp_path / "plan.csv").exists()


def test_no_command_writes_over_the_description_it_read(tmp_path):
    path = tmp_path / "arm.urdf"
    path.write_text(KUKA)
    done = subprocess.run(
        [
            *(sys.executable, "-m", "calibrator", "plan", "--model", str(path)),
            # --force: replacing an earlier output is allowed, the description never.
            *("--tracker-at", "2500,300,300", "-o", str(path), "--force"),
        ],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert done.returncode == 2
    assert "refusing to overwrite" in done.stderr and len(done.stderr.strip().splitlines()) == 1
    assert path.read_text() == KUKA
