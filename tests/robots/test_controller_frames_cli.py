"""The command line refuses a bad ``frames:`` section in one line, exit 2, nothing written.

In new processes (``python -m calibrator``); the messages of every bad
section are tested in process in test_controller_frames.py.
"""

import subprocess
import sys
from pathlib import Path

import pytest

from calibrator import robots

DATA = Path(robots.__file__).with_name("data")


@pytest.mark.parametrize(
    "frames, says",
    [
        ("  base: {link: link_3, source: s}\n", "base: link: 'link_3' is not a link fixed"),
        ("  base: {xyz_mm: [0, 0, 1], source: s}\n", "rpy_deg: missing"),
    ],
)  # fmt: skip
def test_a_bad_frames_section_is_refused_in_one_line_by_the_command(tmp_path, frames, says):
    (tmp_path / "arm.urdf").write_text((DATA / "fanuc-m20ia.urdf").read_text())
    path = tmp_path / "arm.yaml"
    path.write_text(
        "format: calibrator-robot/1\nname: my-m20ia\nsource: a test\n"
        "kinematics:\n  urdf: arm.urdf\n  tip_link: flange\n"
        "body:\n  margin_mm: 10\n  base_radius_mm: 200\n  base_top_mm: 300\n"
        "  link_radius_mm: [90, 80, 70, 60, 50, 40]\nframes:\n" + frames
    )
    done = subprocess.run(
        [sys.executable, "-m", "calibrator", "plan", "--model", str(path), "-o", "p.csv"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2 and says in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
    assert "Traceback" not in done.stderr and not (tmp_path / "p.csv").exists()
