"""docs/cell.md: its Python blocks run as written, its cell file example reads."""

import re
from pathlib import Path

import yaml

from calibrator import cell

DOC = Path(__file__).resolve().parents[2] / "docs" / "cell.md"


def _blocks(kind):
    return re.findall(rf"^```{kind}\n(.*?)^```$", DOC.read_text(), flags=re.S | re.M)


def test_python_blocks_run(capsys):
    blocks = _blocks("python")
    assert blocks
    for block in blocks:
        exec(compile(block, str(DOC), "exec"), {})
    assert "plan pose 0: below mounting plane: elbow" in capsys.readouterr().out


def test_cell_file_example_reads():
    (example,) = _blocks("yaml")
    got = cell.parse_cell(yaml.safe_load(example))
    assert got.tracker_at_mm == (2500.0, 400.0, 300.0)
    assert [b.name for b in got.boxes] == ["table"] and [c.name for c in got.cylinders] == [
        "tripod"
    ]
