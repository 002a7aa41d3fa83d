"""Output files: refused in one line naming the user's path, atomic, all or nothing."""

import os
import tempfile
from pathlib import Path

import pytest
from cli_kit import cli, listing, one_line_error
from hypothesis import given, settings
from hypothesis import strategies as st

from calibrator import outputs


@pytest.fixture(scope="module")
def work(simulated_calibration):
    """A session and its calibration, made once per run (conftest); tests copy them."""
    return simulated_calibration


@pytest.fixture
def folder(tmp_path, work):
    for name, data in work.items():
        (tmp_path / name).write_bytes(data)
    (tmp_path / "adir").mkdir()
    return tmp_path


@pytest.mark.parametrize(
    "args, path",
    [
        (["identify", "s.parquet", "--method", "lm", "-o", "nodir/out.json"], "nodir/out.json"),
        (["identify", "s.parquet", "--method", "lm", "-o", "adir"], "adir"),
        (["identify", "s.parquet", "--method", "lm", "--report", "c.json"], "c.json"),
        (["identify", "s.parquet", "--method", "lm", "--report", "nodir/rep"], "nodir/rep"),
        (["simulate", "-o", "nodir/t.parquet"], "nodir/t.parquet"),
        (["simulate", "-o", "adir"], "adir"),
        (["export-params", "c.json", "-o", "nodir/p.csv"], "nodir/p.csv"),
        (["export-params", "c.json", "-o", "adir"], "adir"),
        (["report", "c.json", "-o", "s.parquet"], "s.parquet"),
        (["report", "c.json", "-o", "nodir/rep"], "nodir/rep"),
    ],
)
def test_bad_output_path_is_one_line_naming_it(folder, args, path):
    before = listing(folder)
    line = one_line_error(cli(*args, cwd=folder))
    assert path in line and ".tmp" not in line and "errno" not in line
    assert listing(folder) == before  # nothing written, nothing left behind


def test_simulate_leaves_nothing_when_the_truth_cannot_be_written(folder):
    (folder / "t.truth.json").mkdir()
    before = listing(folder)
    assert "t.truth.json" in one_line_error(cli("simulate", "-o", "t.parquet", cwd=folder))
    assert listing(folder) == before and not (folder / "t.parquet").exists()


def test_simulate_refuses_a_truth_name_too_long_before_writing(tmp_path):
    # 253 characters fit a file name, the truth's 256 do not.
    stem = "x" * 245
    line = one_line_error(cli("simulate", "-o", f"{stem}.parquet", "--poses", "3", cwd=tmp_path))
    assert f"cannot write {stem}.truth.json: File name too long" in line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "args, input_name",
    [
        (["identify", "s.parquet", "-o", "s.parquet"], "s.parquet"),
        (["identify", "s.parquet", "-o", "./s.parquet", "--method", "lm"], "s.parquet"),
        (["export-params", "c.json", "-o", "c.json"], "c.json"),
        (["export-params", "c.json", "--format", "csv", "-o", "adir/../c.json"], "c.json"),
        (["report", "c.json", "s.parquet", "-o", "s.parquet"], "s.parquet"),
        (["report", "adir/index.html", "-o", "adir"], "adir/index.html"),
    ],
)
def test_no_command_overwrites_its_input(folder, args, input_name):
    (folder / "adir" / "index.html").write_bytes((folder / "c.json").read_bytes())
    before = listing(folder)
    line = one_line_error(cli(*args, cwd=folder))
    assert input_name in line
    assert listing(folder) == before  # the input byte for byte, and nothing else


def test_input_reached_through_a_link_is_refused(folder):
    (folder / "link.json").symlink_to("c.json")
    before = listing(folder)
    line = one_line_error(cli("export-params", "c.json", "-o", "link.json", cwd=folder))
    assert "link.json" in line and listing(folder) == before


def test_output_through_a_symlink_writes_its_target(folder):
    (folder / "real.csv").write_text("old")
    (folder / "link.csv").symlink_to("real.csv")
    refused = one_line_error(cli("export-params", "c.json", "-o", "link.csv", cwd=folder))
    assert "link.csv exists" in refused and (folder / "real.csv").read_text() == "old"
    done = cli(
        "export-params", "c.json", "--format", "csv", "-o", "link.csv", "--force", cwd=folder
    )
    assert done.code == 0, done.stderr
    assert (folder / "link.csv").is_symlink() and (folder / "real.csv").read_text().startswith(
        "element,parameter,"
    )


# --- the outputs module itself ------------------------------------------------


def test_a_failing_second_file_leaves_nothing(tmp_path):
    (tmp_path / "a.txt").write_text("A-old")
    outputs.check(tmp_path / "a.txt", force=True)  # the command's --force clears it
    before = listing(tmp_path)

    def broken(tmp):
        Path(tmp).write_text("partial")
        raise OSError(28, "No space left on device")

    with pytest.raises(outputs.OutputError, match=r"cannot write .*b\.txt: No space left"):
        with outputs.Outputs() as out:
            out.text(tmp_path / "a.txt", "A-new")
            out.file(tmp_path / "b.txt", broken)
    assert listing(tmp_path) == before


def test_a_failing_rename_puts_back_what_was_replaced(tmp_path):
    (tmp_path / "a.txt").write_text("A-old")
    outputs.check(tmp_path / "a.txt", force=True)  # the command's --force clears it
    batch = outputs.Outputs()
    batch.text(tmp_path / "a.txt", "A-new")
    batch.text(tmp_path / "b.txt", "B")
    (tmp_path / "b.txt").mkdir()  # appears after the checks: the second rename fails
    (tmp_path / "b.txt" / "keep").write_text("x")
    before = listing(tmp_path)
    before = {k: v for k, v in before.items() if not k.startswith(".")}
    with pytest.raises(outputs.OutputError, match="b.txt"):
        batch.commit()
    assert listing(tmp_path) == before  # a.txt is A-old again, no temporary or backup file


def test_a_new_folder_is_removed_when_the_batch_fails(tmp_path):
    with pytest.raises(RuntimeError):
        with outputs.Outputs() as out:
            folder = out.folder(tmp_path / "rep")
            out.text(folder / "x.html", "<p>")
            raise RuntimeError("rendering failed")
    assert list(tmp_path.iterdir()) == []


def test_written_files_get_ordinary_permissions(tmp_path):
    outputs.write_text(tmp_path / "x.txt", "x")
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "x.txt").stat().st_mode & 0o777 == 0o666 & ~umask


# --- fuzz: any output path is either written whole or refused naming it -------------

_PARTS = st.sampled_from(
    ["", ".", "..", "adir", "nodir", "c.json", "out.csv", "a b.csv", "é.csv", "x" * 250, "y" * 300]
)


def _inside(path):
    # Relative paths that stay inside the test's folder: a fuzz test must
    # never write anywhere else (an absolute "/x" or "../x" would).
    normal = os.path.normpath(path)
    return not os.path.isabs(path) and normal != ".." and not normal.startswith("../")


_PATHS = st.one_of(
    st.lists(_PARTS, min_size=1, max_size=3).map("/".join),
    st.text(st.characters(blacklist_categories=["Cs"]), min_size=1, max_size=12),
).filter(_inside)


@settings(max_examples=120, deadline=None)
@given(path=_PATHS, fmt=st.sampled_from(["csv", "json"]))
def test_fuzz_export_output_paths(work, path, fmt):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name) / "a" / "b"  # a stray "../" would still land in the temporary tree
        folder.mkdir(parents=True)
        (folder / "c.json").write_bytes(work["c.json"])
        (folder / "adir").mkdir()
        before = listing(folder)
        result = cli("export-params", "c.json", "--format", fmt, "-o", path, cwd=folder)
        after = listing(folder)
        if result.code == 0:
            target = (folder / path).resolve()
            assert target.is_file() and target.stat().st_size > 0
            new = {k for k in after if k not in before}
            assert not [k for k in new if k.endswith(".tmp")], new
            assert after.get("c.json") == work["c.json"]
        else:
            line = one_line_error(result)
            # Named as given or as the path it reads as ('\x00/' is shown quoted, as typed).
            shown = (str(Path(path)), repr(str(Path(path))), repr(path))
            assert any(name in line for name in shown), line
            assert after == before


@settings(max_examples=40, deadline=None)
@given(path=_PATHS)
def test_fuzz_simulate_output_paths_both_files_or_neither(path):
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name) / "a" / "b"
        folder.mkdir(parents=True)
        (folder / "adir").mkdir()
        before = listing(folder)
        result = cli("simulate", "--poses", "3", "-o", path, cwd=folder)
        after = listing(folder)
        if result.code == 0:
            session_file = (folder / path).resolve()
            truth = session_file.with_suffix(".truth.json")
            assert session_file.is_file() and truth.is_file()
            assert len(after) == len(before) + 2  # the session and its truth, nothing else
            assert not [k for k in after if k.endswith((".tmp", ".old"))]
        else:
            line = one_line_error(result)
            shown = (str(Path(path)), repr(str(Path(path))), repr(path), ".truth.json")
            assert any(name in line for name in shown), line
            assert after == before
