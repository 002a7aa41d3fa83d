"""``history import`` of a deeply nested JSON: one line about it, the rest imported."""

import shutil

from cli_kit import cli


def test_a_deeply_nested_json_is_skipped_in_one_line_and_the_import_goes_on(measured, tmp_path):
    folder = tmp_path / "files"
    folder.mkdir()
    shutil.copy(measured / "s0.parquet", folder / "s0.parquet")
    shutil.copy(measured / "cal0.json", folder / "cal0.json")
    depth = 200_000
    (folder / "a-deep.json").write_text(
        '{"format": "calibrator.check", "x": ' + "[" * depth + "]" * depth + "}"
    )
    done = cli("history", "import", "files", "--history", "h.sqlite", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "a-deep.json: JSON nested too deeply to read" in lines[0], lines
    assert "1 sessions, 1 calibrations" in done.stdout, done.stdout
