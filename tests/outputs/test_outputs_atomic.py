"""calibrator.outputs in process: every refusal's exact line, atomic writes, nothing left behind."""

import os
from pathlib import Path

import pytest
from cli_kit import listing

from calibrator import outputs
from calibrator.errors import CalibrationError


def refused(call, *args, **kwargs):
    with pytest.raises(outputs.OutputError) as caught:
        call(*args, **kwargs)
    assert isinstance(caught.value, CalibrationError)
    return str(caught.value)


@pytest.fixture
def no_write_permission(monkeypatch):
    """Make ``os.access`` say no for the folders put in the returned set (tests run as root)."""
    denied = set()
    real = os.access

    def access(path, mode, **kwargs):
        if Path(path) in denied and mode & os.W_OK:
            return False  # readable and searchable, not writable
        return real(path, mode, **kwargs)

    monkeypatch.setattr(os, "access", access)
    return denied


# --- check: a file ---------------------------------------------------------------


def test_check_accepts_a_new_file_or_with_force_an_existing_one_and_returns_a_path(tmp_path):
    (tmp_path / "old.json").write_text("{}")
    assert outputs.check(str(tmp_path / "new.json")) == tmp_path / "new.json"
    assert outputs.check(tmp_path / "old.json", inputs=[None, tmp_path / "other"], force=True) == (
        tmp_path / "old.json"
    )
    with pytest.raises(outputs.OutputError, match=r"old.json exists: .* another --json, or pass"):
        outputs.check(tmp_path / "old.json", option="--json")
    # A folder holding a file the command writes is an existing output; others are not.
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "notes.txt").write_text("mine")
    assert outputs.check_folder(tmp_path / "rep", files=["index.html"]) == tmp_path / "rep"
    (tmp_path / "rep" / "index.html").write_text("old")
    with pytest.raises(outputs.OutputError, match=r"index.html exists: .* another --report,"):
        outputs.check_folder(tmp_path / "rep", files=["index.html"], option="--report")
    assert outputs.check_folder(tmp_path / "rep", files=["index.html"], force=True)


def test_check_refusals_name_the_path(tmp_path, no_write_permission):
    (tmp_path / "adir").mkdir()
    (tmp_path / "afile").write_text("x")
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "locked").mkdir()
    no_write_permission.add(tmp_path / "locked")
    p = tmp_path
    assert (
        refused(outputs.check, p / "adir")
        == f"cannot write {p}/adir: it is a folder; give a file name"
    )
    assert refused(outputs.check, p / "fifo") == (
        f"cannot write {p}/fifo: it exists and is not a regular file"
    )
    assert refused(outputs.check, p / "nodir" / "x.json") == (
        f"cannot write {p}/nodir/x.json: folder {p}/nodir does not exist"
    )
    assert refused(outputs.check, p / "afile" / "x.json") == (
        f"cannot write {p}/afile/x.json: {p}/afile is not a folder"
    )
    assert refused(outputs.check, p / "locked" / "x.json") == (
        f"cannot write {p}/locked/x.json: no permission to write in {p}/locked"
    )
    assert refused(outputs.check, f"{p}/a\0b") == (
        f"cannot write '{p}/a\\x00b': a file name cannot hold a NUL character"
    )
    assert refused(outputs.check, p / ("n" * 300)) == (
        f"cannot write {p}/{'n' * 300}: File name too long"
    )


def test_check_refuses_an_input_however_it_is_reached(tmp_path):
    (tmp_path / "s.parquet").write_text("data")
    os.symlink(tmp_path / "s.parquet", tmp_path / "link.parquet")
    os.link(tmp_path / "s.parquet", tmp_path / "hard.parquet")
    says = "refusing to overwrite {}: it is an input of this command; choose another output"
    for path in ("s.parquet", "link.parquet", "hard.parquet"):
        out = tmp_path / path
        assert refused(outputs.check, out, inputs=[None, tmp_path / "s.parquet"]) == says.format(
            out
        )
    assert (tmp_path / "s.parquet").read_text() == "data"


# --- check_folder ----------------------------------------------------------------


def test_check_folder_accepts_a_new_or_existing_folder(tmp_path):
    (tmp_path / "rep").mkdir()
    assert outputs.check_folder(tmp_path / "rep") == tmp_path / "rep"
    assert outputs.check_folder(str(tmp_path / "new"), inputs=[None]) == tmp_path / "new"


def test_check_folder_refusals_name_the_path(tmp_path, no_write_permission):
    (tmp_path / "afile").write_text("x")
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "locked").mkdir()
    (tmp_path / "open").mkdir()
    no_write_permission.add(tmp_path / "locked")
    p = tmp_path
    for name in ("afile", "fifo"):
        assert refused(outputs.check_folder, p / name) == (
            f"cannot write into {p}/{name}: it exists and is not a folder"
        )
    assert refused(outputs.check_folder, p / "locked") == (
        f"cannot write into {p}/locked: no permission to write there"
    )
    assert refused(outputs.check_folder, p / "nodir" / "rep") == (
        f"cannot write {p}/nodir/rep: folder {p}/nodir does not exist"
    )
    assert refused(outputs.check_folder, p / "open", inputs=[None, p / "open"]) == (
        f"refusing to write into {p}/open: it is an input of this command"
    )
    assert refused(outputs.check_folder, f"{p}/r\0") == (
        f"cannot write '{p}/r\\x00': a file name cannot hold a NUL character"
    )


# --- writing ---------------------------------------------------------------------


def test_write_text_and_write_with_write_whole_files_and_nothing_else(tmp_path):
    assert outputs.write_text(str(tmp_path / "a.txt"), "é\n") == tmp_path / "a.txt"
    assert (tmp_path / "a.txt").read_bytes() == "é\n".encode()
    seen = {}

    def writer(tmp):
        seen["tmp"] = Path(tmp)
        seen["target there"] = (tmp_path / "b.bin").exists()
        Path(tmp).write_bytes(b"\x00\x01")

    assert outputs.write_with(tmp_path / "b.bin", writer) == tmp_path / "b.bin"
    assert seen["tmp"].parent == tmp_path and seen["tmp"].name.startswith(".b.bin.")
    assert seen["tmp"].name.endswith(".tmp") and not seen["target there"]
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"
    assert sorted(listing(tmp_path)) == ["a.txt", "b.bin"]


def test_write_text_refuses_its_input(tmp_path):
    (tmp_path / "c.json").write_text("in")
    assert refused(outputs.write_text, tmp_path / "c.json", "out", inputs=[tmp_path / "c.json"])
    assert listing(tmp_path) == {"c.json": b"in"}
    with pytest.raises(outputs.OutputError):
        outputs.write_with(tmp_path / "c.json", lambda t: None, inputs=[tmp_path / "c.json"])
    assert listing(tmp_path) == {"c.json": b"in"}


def test_a_name_as_long_as_the_file_system_allows_can_be_written(tmp_path):
    name = "x" * 250 + ".json"
    outputs.write_text(tmp_path / name, "{}")
    assert listing(tmp_path) == {name: b"{}"}


def test_nothing_is_renamed_before_the_batch_ends(tmp_path):
    (tmp_path / "a.txt").write_text("A-old")
    outputs.check(tmp_path / "a.txt", force=True)  # the command's --force clears it
    with outputs.Outputs() as out:
        assert out.text(str(tmp_path / "a.txt"), "A-new") == tmp_path / "a.txt"
        assert out.bytes(tmp_path / "b.bin", b"B") == tmp_path / "b.bin"
        assert (tmp_path / "a.txt").read_text() == "A-old"
        assert not (tmp_path / "b.bin").exists()
    assert listing(tmp_path) == {"a.txt": b"A-new", "b.bin": b"B"}
    out.commit()  # a second commit does nothing
    assert listing(tmp_path) == {"a.txt": b"A-new", "b.bin": b"B"}


def test_one_file_twice_in_a_batch_is_refused_and_nothing_is_written(tmp_path):
    os.symlink(tmp_path / "a.txt", tmp_path / "alias.txt")
    with pytest.raises(outputs.OutputError) as caught:
        with outputs.Outputs() as out:
            out.text(tmp_path / "a.txt", "one")
            out.text(tmp_path / "alias.txt", "two")
    assert str(caught.value) == f"cannot write {tmp_path}/alias.txt twice in one command"
    assert sorted(listing(tmp_path)) == ["alias.txt"]  # the dangling link the test made


def test_a_writer_error_leaves_nothing_and_names_the_file(tmp_path):
    def full_disk(tmp):
        Path(tmp).write_text("half")
        raise OSError(28, "No space left on device")

    out = outputs.Outputs()
    out.text(tmp_path / "first.txt", "1")
    message = refused(out.file, tmp_path / "second.txt", full_disk)
    assert message == f"cannot write {tmp_path}/second.txt: No space left on device"
    assert listing(tmp_path) == {}
    out.commit()  # the failed batch is closed: nothing appears
    assert listing(tmp_path) == {}


def test_a_writer_error_inside_a_batch_block_is_the_error_raised(tmp_path):
    def full_disk(tmp):
        raise OSError(28, "No space left on device")

    # The failing file discards the batch, then leaving the block discards it again.
    with pytest.raises(outputs.OutputError, match="^cannot write .*b.txt: No space left"):
        with outputs.Outputs() as out:
            out.text(out.folder(tmp_path / "rep") / "a.txt", "A")
            out.file(tmp_path / "rep" / "b.txt", full_disk)
    assert listing(tmp_path) == {}


def test_any_other_writer_error_passes_through_and_leaves_nothing(tmp_path):
    def broken(tmp):
        Path(tmp).write_text("half")
        raise ValueError("bad table")

    out = outputs.Outputs()
    out.text(tmp_path / "first.txt", "1")
    with pytest.raises(ValueError, match="bad table"):
        out.file(tmp_path / "second.txt", broken)
    assert listing(tmp_path) == {}


def _rename_fails_on_second(tmp_path, monkeypatch, link_works=True):
    (tmp_path / "a.txt").write_text("A-old")
    outputs.check(tmp_path / "a.txt", force=True)  # the command's --force clears it
    batch = outputs.Outputs()
    batch.text(tmp_path / "a.txt", "A-new")
    batch.text(tmp_path / "new.txt", "N")
    batch.text(tmp_path / "b.txt", "B")
    (tmp_path / "b.txt").mkdir()  # appears after the checks: the third rename fails
    if not link_works:

        def no_links(*args, **kwargs):
            raise OSError(1, "Operation not permitted")

        monkeypatch.setattr(os, "link", no_links)
    inode = (tmp_path / "a.txt").stat().st_ino
    with pytest.raises(outputs.OutputError) as caught:
        batch.commit()
    assert str(caught.value) == f"cannot write {tmp_path}/b.txt: Is a directory"
    return inode


def test_a_failed_rename_puts_back_the_old_file_itself_and_removes_new_ones(tmp_path, monkeypatch):
    inode = _rename_fails_on_second(tmp_path, monkeypatch)
    assert listing(tmp_path) == {"a.txt": b"A-old", "b.txt": None}
    assert (tmp_path / "a.txt").stat().st_ino == inode  # the same file, not a copy


def test_without_hard_links_the_old_file_is_put_back_from_a_copy(tmp_path, monkeypatch):
    _rename_fails_on_second(tmp_path, monkeypatch, link_works=False)
    assert listing(tmp_path) == {"a.txt": b"A-old", "b.txt": None}


def test_the_second_name_is_hidden_beside_the_target_and_holds_its_content(tmp_path):
    target = tmp_path / "cal.json"
    target.write_text("old")
    second = outputs._second_name(target)
    assert second.parent == tmp_path
    assert second.name.startswith(".cal.json.") and second.name.endswith(".old")
    assert second.read_text() == "old" and os.path.samefile(second, target)


def test_a_second_name_that_cannot_be_made_leaves_nothing(tmp_path, monkeypatch):
    target = tmp_path / "cal.json"
    target.write_text("old")

    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "link", fail)
    monkeypatch.setattr(outputs.shutil, "copy2", fail)
    with pytest.raises(OSError, match="No space"):
        outputs._second_name(target)
    assert listing(tmp_path) == {"cal.json": b"old"}


def test_folders_made_by_a_failed_batch_are_removed_innermost_first(tmp_path):
    with pytest.raises(RuntimeError):
        with outputs.Outputs() as out:
            outer = out.folder(tmp_path / "rep")
            inner = out.folder(str(outer / "img"))
            assert inner == tmp_path / "rep" / "img" and inner.is_dir()
            out.text(inner / "x.png", "png")
            raise RuntimeError("drawing failed")
    assert listing(tmp_path) == {}


def test_a_failed_batch_keeps_an_existing_folder_and_files_the_user_put_in_a_new_one(tmp_path):
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "mine.txt").write_text("mine")
    with pytest.raises(RuntimeError):
        with outputs.Outputs() as out:
            out.folder(tmp_path / "old")
            new = out.folder(tmp_path / "new")
            (new / "theirs.txt").write_text("theirs")
            out.text(tmp_path / "old" / "x.html", "<p>")
            raise RuntimeError
    assert listing(tmp_path) == {
        "new": None,
        "new/theirs.txt": b"theirs",
        "old": None,
        "old/mine.txt": b"mine",
    }


def test_a_committed_batch_keeps_its_new_folder(tmp_path):
    with outputs.Outputs(inputs=[None]) as out:
        out.text(out.folder(tmp_path / "rep") / "index.html", "<p>")
    out.discard()  # after the commit: nothing pending, the folder stays
    assert listing(tmp_path) == {"rep": None, "rep/index.html": b"<p>"}


def test_a_folder_that_cannot_be_created_is_one_line(tmp_path, monkeypatch):
    def fail(self, *args, **kwargs):
        raise OSError(13, "Permission denied")

    monkeypatch.setattr(Path, "mkdir", fail)
    out = outputs.Outputs()
    assert refused(out.folder, tmp_path / "rep") == (
        f"cannot create folder {tmp_path}/rep: Permission denied"
    )


def test_a_temporary_file_that_cannot_be_made_discards_the_batch(tmp_path, monkeypatch):
    out = outputs.Outputs()
    out.text(tmp_path / "first.txt", "1")

    def fail(*args, **kwargs):
        raise OSError(24, "Too many open files")

    monkeypatch.setattr(outputs.tempfile, "mkstemp", fail)
    assert refused(out.text, tmp_path / "second.txt", "2") == (
        f"cannot write {tmp_path}/second.txt: Too many open files"
    )
    monkeypatch.undo()
    assert listing(tmp_path) == {}


# --- messages --------------------------------------------------------------------


def test_show_quotes_only_unprintable_paths():
    assert outputs.show(Path("out/cal é.json")) == "out/cal é.json"
    assert outputs.show("a\nb") == "'a\\nb'"
    assert outputs.show("tab\there") == "'tab\\there'"


def test_reason_is_the_system_message_or_the_first_line():
    assert outputs._reason(OSError(28, "No space left on device")) == "No space left on device"
    assert outputs._reason(OSError("  first line\nsecond  ")) == "first line"
    assert outputs._reason(OSError("")) == "OSError"
    assert outputs._reason(PermissionError()) == "PermissionError"


def test_a_batch_refuses_a_folder_that_is_one_of_its_inputs(tmp_path):
    (tmp_path / "frames").mkdir()
    out = outputs.Outputs(inputs=[tmp_path / "frames"])
    assert refused(out.folder, tmp_path / "frames") == (
        f"refusing to write into {tmp_path}/frames: it is an input of this command"
    )


def test_a_temporary_file_gone_before_the_rename_puts_everything_back(tmp_path):
    (tmp_path / "a.txt").write_text("A-old")
    outputs.check(tmp_path / "a.txt", force=True)  # the command's --force clears it
    (tmp_path / "b.txt").write_text("B-old")
    outputs.check(tmp_path / "b.txt", force=True)
    before = listing(tmp_path)
    batch = outputs.Outputs()
    batch.text(tmp_path / "a.txt", "A-new")
    batch.text(tmp_path / "b.txt", "B-new")
    (temporary,) = tmp_path.glob(".b.txt.*.tmp")
    temporary.unlink()  # removed by someone else: the second rename fails
    with pytest.raises(outputs.OutputError, match="^cannot write .*b.txt: No such file"):
        batch.commit()
    assert listing(tmp_path) == before  # both old files, no second name left behind


@pytest.mark.parametrize("umask", [0o022, 0o027, 0o077])
def test_written_files_get_the_permissions_of_any_new_file(tmp_path, umask):
    old = os.umask(umask)
    try:
        outputs.write_text(tmp_path / "x.txt", "x")
        assert os.umask(old) == umask  # the process umask is left as it was
    finally:
        os.umask(old)
    assert (tmp_path / "x.txt").stat().st_mode & 0o777 == 0o666 & ~umask


def test_an_existing_file_no_check_cleared_is_refused_like_o_without_force(tmp_path):
    # A companion a command writes beside its output (KRL's OUT.dat beside
    # -o OUT.src) is protected like -o: without a check under --force, an
    # existing one is refused and stays as it was.
    (tmp_path / "OUT.dat").write_text("the user's")
    outputs.check(tmp_path / "OUT.src", force=False)  # -o checked; the .dat was not
    with pytest.raises(outputs.OutputError, match=r"OUT\.dat exists: remove it.*--force"):
        with outputs.Outputs() as out:
            out.text(tmp_path / "OUT.src", "src")
            out.text(tmp_path / "OUT.dat", "dat")
    assert listing(tmp_path) == {"OUT.dat": b"the user's"}
    # What this process wrote itself it may replace again (a file rewritten as a run goes).
    outputs.write_text(tmp_path / "run.txt", "1")
    outputs.write_text(tmp_path / "run.txt", "2")
    assert (tmp_path / "run.txt").read_text() == "2"
