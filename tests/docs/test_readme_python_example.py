"""The README's Python example writes the calibration.json ``calibrator identify`` writes.

``calibrator.identify.calibrate`` is the whole command in Python: run the
README's block as written, then the command on the session it made, with the
same ``SOURCE_DATE_EPOCH`` (the provenance's time): the two files are equal
byte for byte.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

from cli_kit import cli

README = Path(__file__).resolve().parents[2] / "README.md"


def test_the_python_example_and_the_command_write_the_same_file(tmp_path, monkeypatch):
    block = re.search(r"## In Python\n\n```python\n(.*?)```", README.read_text(), re.S)
    assert block, "README has an 'In Python' block"
    (tmp_path / "example.py").write_text(block.group(1))
    env = {**os.environ, "SOURCE_DATE_EPOCH": "1700000000"}
    done = subprocess.run(
        [sys.executable, "example.py"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert "held-out position error: 0.0" in done.stdout
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    command = cli("identify", "session.parquet", "-o", "command.json", "-q", cwd=tmp_path)
    assert command.code == 0, command.stderr
    assert (tmp_path / "calibration.json").read_bytes() == (tmp_path / "command.json").read_bytes()
    assert '"created": "2023-11-14T22:13:20+00:00"' in (tmp_path / "command.json").read_text()
