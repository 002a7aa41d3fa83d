"""Older corpora: frames no session could have, journals of an unknown version."""

import json

import pytest
from cli_kit import cli, listing, one_line_error

from calibrator import export


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frames")
    done = cli("simulate", "--model", "ur10e", "--poses", "30", "-o", "s.parquet", cwd=folder)
    assert done.code == 0, done.stderr
    done = cli("identify", "s.parquet", "--method", "lm", "-o", "cal.json", "-q", cwd=folder)
    assert done.code == 0, done.stderr
    return folder


EDITS = {
    "a tool 9e11 mm off": (("flange2tool", 0, 3, 9e11), "'flange2tool' puts the tool 9e+11 mm"),
    "a first-guess tool": (("tool0", 2, 3, -2e5), "'tool0' puts the tool 200000 mm"),
    "a base 1e11 mm off": (("base2tracker", 1, 3, 1e11), "'base2tracker' puts the robot base"),
}


@pytest.mark.parametrize("fmt", export.format_names())
@pytest.mark.parametrize("edit", sorted(EDITS))
def test_export_refuses_a_frame_no_session_could_have(made, fmt, edit):
    (key, row, col, value), says = EDITS[edit]
    doc = json.loads((made / "cal.json").read_text())
    doc[key][row][col] = value
    (made / "far.json").write_text(json.dumps(doc))
    before = listing(made)
    suffix = export.REGISTRY[fmt].suffixes[0]
    line = one_line_error(
        cli("export-params", "far.json", "--format", fmt, "-o", f"out{suffix}", cwd=made)
    )
    assert line.startswith("calibrator: error: far.json: ") and says in line, line
    assert listing(made) == before


def test_the_identified_calibration_exports(made):
    done = cli("export-params", "cal.json", "--format", "csv", cwd=made)
    assert done.code == 0, done.stderr


@pytest.mark.parametrize("version", ["99", "2.0", "true", '"2"'])
def test_a_journal_of_an_unknown_version_is_not_resumed(tmp_path, version):
    journal = tmp_path / "s.parquet.journal"
    journal.write_text(f'{{"format": "calibrator.journal", "version": {version}}}\n')
    before = listing(tmp_path)
    line = one_line_error(
        cli("measure", "--robot", "sim", "--tracker", "sim", "--poses", "30", "-o", "s.parquet",
            "--resume", "--yes", "-q", cwd=tmp_path)
    )  # fmt: skip
    assert "s.parquet.journal: journal version" in line and "is not supported" in line
    assert listing(tmp_path) == before
