"""Output files that never surprise: checked first, written atomically, all or nothing.

Every file a command writes goes through here, so that

- a bad output path is refused before any work, in one line naming the
  user's path (a missing folder, a folder given as a file, an input of the
  command, a folder without write permission);
- an existing output is refused unless the user passed ``--force`` (one
  policy for every command; the message names the option that gave the
  path: ``-o``, ``--report``...). Commands apply it in their first check,
  before any work; the writers below then replace only what a check cleared
  (or what this process wrote itself): a companion file a command writes
  beside its output (KRL's ``OUT.dat`` beside ``-o OUT.src``) that no check
  cleared is refused like ``-o`` when it exists, never silently replaced;
- a file appears whole or not at all: it is written to a hidden temporary
  file beside the target, flushed to disk, then renamed over it;
- nothing is left behind after a failure, not even when the second of
  several outputs fails: a :class:`Outputs` batch renames its files only
  once all of them are written, and puts back what it replaced if a rename
  fails.

API::

    from calibrator import outputs

    outputs.check(path, inputs=[session_path], force=force)  # before the work; returns the Path
    outputs.write_text(path, text, inputs=[...])   # one file
    outputs.write_with(path, lambda tmp: pq.write_table(table, tmp))

    with outputs.Outputs(inputs=[session_path]) as out:   # several, all or nothing
        out.text(path_a, text)
        out.file(path_b, writer)        # writer(tmp_path) writes the whole file
        out.bytes(folder / "x.png", data)
        out.folder(report_dir)          # created if missing, removed again on failure
    # committed here; an exception inside the block leaves no trace of it

Errors are :class:`OutputError` (a :class:`~calibrator.errors.CalibrationError`):
the CLI prints them as one line and exits with code 2.
"""

from __future__ import annotations

import builtins
import os
import shutil
import stat
import tempfile
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from calibrator.errors import CalibrationError

#: A file name as the commands take it.
PathLike = str | os.PathLike

__all__ = [
    "OutputError",
    "Outputs",
    "check",
    "check_folder",
    "existing",
    "note_input",
    "show",
    "write_text",
    "write_with",
]


class OutputError(CalibrationError):
    """An output path that cannot or must not be written."""


#: Files this process read as inputs besides those a command names (a robot
#: description given as ``--model arm.urdf``): no output may overwrite them.
_NOTED: set[Path] = set()


def note_input(path: PathLike) -> None:
    """Record a file this process read, so that no output overwrites it."""
    _NOTED.add(Path(path))


#: Output paths (resolved) this process may replace: cleared by :func:`check`
#: under the user's ``--force`` policy, or written by this process itself.
_CLEARED: set[Path] = set()


def _clear(path: Path) -> None:
    try:
        _CLEARED.add(path.resolve())
    except (OSError, RuntimeError):  # a loop of links: never cleared, so refused if it exists
        pass


def check(
    path: PathLike,
    inputs: Iterable[PathLike | None] = (),
    *,
    force: bool = False,
    option: str = "-o",
) -> Path:
    """Refuse an output path that cannot or must not be written.

    Parameters
    ----------
    path : str or Path
        The output file as the user gave it.
    inputs : iterable of str or Path
        Files the command reads; none of them may be overwritten (None: an
        optional input not given, skipped).
    force : bool
        The user's ``--force``: an existing file may be replaced. Without
        it an existing file is refused.
    option : str
        The option that named ``path``, for the message.

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        One line naming ``path``.
    """
    path = _no_nul(path)
    kind = _kind(path)
    if kind == "folder":
        raise OutputError(f"cannot write {show(path)}: it is a folder; give a file name")
    if kind == "other":
        raise OutputError(f"cannot write {show(path)}: it exists and is not a regular file")
    for source in [*inputs, *_NOTED]:
        if source is not None and _same_file(path, Path(source)):
            raise OutputError(
                f"refusing to overwrite {show(path)}: it is an input of this command; "
                "choose another output"
            )
    if kind == "file" and not force:
        raise existing(path, option)
    _check_parent(path)
    _clear(Path(path))
    return Path(path)


def existing(path: PathLike, option: str = "-o", resumable: bool = False) -> OutputError:
    """The one refusal of an existing output: what to do instead, naming ``option``.

    ``resumable``: the command can also continue the run that wrote it (``--resume``).
    """
    if resumable:
        return OutputError(
            f"{show(path)} exists: remove it, choose another {option}, pass --force to "
            "replace it, or --resume to continue its run"
        )
    return OutputError(
        f"{show(path)} exists: remove it, choose another {option}, or pass --force to replace it"
    )


def check_folder(
    path: PathLike,
    inputs: Iterable[PathLike | None] = (),
    *,
    files: Iterable[str] = (),
    force: bool = False,
    option: str = "-o",
) -> Path:
    """Refuse an output folder that cannot be used (its parent is checked as for a file).

    An existing folder is fine unless it holds one of ``files`` (the names
    the command writes into it): that is an existing output, refused without
    ``force`` as :func:`check` refuses a file. A missing folder is created by
    :meth:`Outputs.folder`.
    """
    path = _no_nul(path)
    if _kind(path) == "folder":
        for name in files:
            check(Path(path) / name, inputs, force=force, option=option)
    kind = _kind(path)
    if kind not in (None, "folder"):
        raise OutputError(f"cannot write into {show(path)}: it exists and is not a folder")
    for source in [*inputs, *_NOTED]:
        if source is not None and _same_file(path, Path(source)):
            raise OutputError(
                f"refusing to write into {show(path)}: it is an input of this command"
            )
    if kind == "folder":
        if not os.access(path, os.W_OK | os.X_OK):
            raise OutputError(f"cannot write into {show(path)}: no permission to write there")
    else:
        _check_parent(path)
    return Path(path)


def _kind(path):
    """``'file'``, ``'folder'``, ``'other'`` or None (nothing there yet)."""
    try:
        mode = os.stat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None  # a parent that is not a folder is reported by _check_parent
    except OSError as exc:  # a name too long, a loop of links, no permission...
        raise OutputError(f"cannot write {show(path)}: {_reason(exc)}") from None
    return "folder" if stat.S_ISDIR(mode) else "file" if stat.S_ISREG(mode) else "other"


def _no_nul(path):
    path = Path(path)
    if "\0" in str(path):
        raise OutputError(f"cannot write {show(path)}: a file name cannot hold a NUL character")
    return path


def _check_parent(path):
    parent = path.parent
    if not parent.exists():
        raise OutputError(f"cannot write {show(path)}: folder {show(parent)} does not exist")
    if not parent.is_dir():
        raise OutputError(f"cannot write {show(path)}: {show(parent)} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write {show(path)}: no permission to write in {show(parent)}")


def _same_file(a, b):
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def write_text(path: PathLike, text: str, inputs: Iterable[PathLike | None] = ()) -> Path:
    """Write one text file (UTF-8) atomically; see :class:`Outputs`."""
    with Outputs(inputs) as out:
        out.text(path, text)
    return Path(path)


def write_with(
    path: PathLike, writer: Callable[[Path], object], inputs: Iterable[PathLike | None] = ()
) -> Path:
    """Write one file atomically with ``writer(tmp_path)``; see :class:`Outputs`."""
    with Outputs(inputs) as out:
        out.file(path, writer)
    return Path(path)


class Outputs:
    """A batch of output files that appear together or not at all.

    Each file is checked (:func:`check`) and written to a hidden temporary
    file in its target folder when added, so most failures happen before
    anything is renamed. Leaving the ``with`` block normally renames every
    file into place; an exception (or a failed rename) removes every
    temporary file, restores any file the batch had replaced, and removes
    folders it created.

    Parameters
    ----------
    inputs : iterable of str or Path
        Files the command reads; none of them may be an output.
    """

    def __init__(self, inputs: Iterable[PathLike | None] = ()) -> None:
        self.inputs = [Path(p) for p in inputs if p is not None]
        self._pending: list[tuple[Path, Path, Path]] = []  # (temporary, target, user's path)
        self._created: list[Path] = []  # folders this batch made
        self._done = False

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb):
        if kind is None:
            self.commit()
        else:
            self.discard()
        return False

    def folder(self, path: PathLike) -> Path:
        """Make sure the output folder ``path`` exists (created now, removed on failure)."""
        path = check_folder(path, self.inputs, force=True)
        if not path.is_dir():
            try:
                path.mkdir()
            except OSError as exc:
                raise OutputError(f"cannot create folder {show(path)}: {_reason(exc)}") from None
            self._created.append(path)
        return path

    def text(self, path: PathLike, text: str) -> Path:
        """Add a UTF-8 text file."""
        return self.bytes(path, text.encode("utf-8"))

    def bytes(self, path: PathLike, data: builtins.bytes) -> Path:
        """Add a file holding ``data``."""

        def save(tmp):
            with open(tmp, "wb") as fh:
                fh.write(data)

        return self.file(path, save)

    def file(self, path: PathLike, writer: Callable[[Path], object]) -> Path:
        """Add a file written by ``writer(tmp_path)`` (it must write the whole file there).

        An existing file is replaced only if :func:`check` cleared it (the
        command applied the ``--force`` policy before its work) or this
        process wrote it; any other existing file is refused like ``-o``
        without ``--force``.

        Returns
        -------
        Path
            The user's path.
        """
        path = Path(path)
        try:
            cleared = path.resolve() in _CLEARED
        except (OSError, RuntimeError):
            cleared = False
        if not cleared and _kind(_no_nul(path)) == "file":
            # No check cleared this existing file (a companion the command
            # writes beside its output): refused as -o would be without --force.
            raise existing(path)
        path = check(path, self.inputs, force=True)
        target = path.resolve()  # through a symlink, never over it
        if any(target == t for _, t, _ in self._pending):
            raise OutputError(f"cannot write {show(path)} twice in one command")
        # A short prefix: a temporary name must fit wherever the target's name fits.
        try:
            fd, name = tempfile.mkstemp(
                prefix=f".{target.name[:40]}.", suffix=".tmp", dir=target.parent
            )
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write {show(path)}: {_reason(exc)}") from None
        os.close(fd)
        tmp = Path(name)
        self._pending.append((tmp, target, path))
        try:
            writer(tmp)
            _make_readable(tmp)
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write {show(path)}: {_reason(exc)}") from None
        except BaseException:
            self.discard()
            raise
        return path

    def commit(self) -> None:
        """Rename every file into place; on any failure put back what was there.

        Each rename is atomic, so a target always holds either its old or
        its new content; an old file is kept under a second (hard-linked)
        name until every file of the batch is in place.
        """
        if self._done:
            return
        kept, placed = {}, []
        try:
            for tmp, target, _ in self._pending:
                if target.exists():
                    kept[target] = _second_name(target)
                os.replace(tmp, target)
                placed.append(target)
        except OSError as exc:
            failed = next(p for _, t, p in self._pending if t not in placed)
            for target in placed:
                if target in kept:
                    os.replace(kept.pop(target), target)
                else:
                    _unlink(target)
            for old in kept.values():
                _unlink(old)
            self.discard()
            raise OutputError(f"cannot write {show(failed)}: {_reason(exc)}") from None
        for old in kept.values():
            _unlink(old)
        for _, target, _ in self._pending:
            _CLEARED.add(target)  # this process wrote it: it may replace it again
        self._pending = []
        self._done = True

    def discard(self) -> None:
        """Remove every temporary file and every folder this batch created."""
        for tmp, _, _ in self._pending:
            _unlink(tmp)
        self._pending = []
        for folder in reversed(self._created):
            try:
                folder.rmdir()  # only if still empty: never remove the user's files
            except OSError:
                pass
        self._created = []
        self._done = True


def _second_name(target):
    """A hidden second name for the file at ``target``, to put it back from."""
    fd, name = tempfile.mkstemp(prefix=f".{target.name[:40]}.", suffix=".old", dir=target.parent)
    os.close(fd)
    try:
        os.unlink(name)
        os.link(target, name)
    except OSError:  # no hard links here (some network or FAT file systems): copy
        try:
            shutil.copy2(target, name)
        except OSError:
            _unlink(name)
            raise
    return Path(name)


def known_format(registry: Mapping[str, object], fmt: str) -> None:
    """Refuse a format name ``registry`` does not hold (one line naming the known ones)."""
    if fmt not in registry:
        raise CalibrationError(f"unknown format {fmt!r}; known: {', '.join(registry)}")


def choose_format(
    registry: Mapping[str, Any],
    fmt: str | None,
    output: PathLike | None,
    default: str | None = None,
) -> str:
    """The format to write: ``fmt`` if given (it must fit the extension), else by extension.

    Parameters
    ----------
    registry : mapping
        Format name -> a format whose ``suffixes`` are the file name endings that
        select it (:data:`calibrator.export.REGISTRY`,
        :func:`calibrator.languages.registry.writers`);
        the longest matching ending wins (``.urcal.conf`` before ``.conf``).
    fmt : str, optional
        The format asked for (``--format``).
    output : path, optional
        The file to write; None: standard output, which has no extension.
    default : str, optional
        The format when neither ``fmt`` nor ``output`` tells.

    Raises
    ------
    CalibrationError
        Unknown format, no way to tell, or a format that does not match the
        output file's extension (``-o out.xml`` with ``--format json``).
    """
    by_suffix = None
    if output is not None:
        name = Path(output).name.lower()
        matches = [
            (len(s), f.name) for f in registry.values() for s in f.suffixes if name.endswith(s)
        ]
        by_suffix = max(matches)[1] if matches else None
    if fmt is not None:
        known_format(registry, fmt)
        if output is not None and by_suffix != fmt:
            want = " or ".join(registry[fmt].suffixes)
            raise CalibrationError(
                f"output {show(output)} does not end in {want}, the extension of format {fmt}"
            )
        return fmt
    if output is None and default is not None:
        return default
    if by_suffix is None:
        known = ", ".join(s for f in registry.values() for s in f.suffixes)
        raise CalibrationError(
            f"cannot tell the format from {show(output or '-')}: "
            f"give --format or end the name in one of {known}"
        )
    return by_suffix


def show(path: PathLike) -> str:
    """A path for a one-line message: as typed, or quoted if it holds control characters."""
    text = str(path)
    return text if text.isprintable() else repr(text)


def _make_readable(tmp):
    # mkstemp makes 0600 files; outputs get the permissions of any new file.
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)


def _unlink(path):
    try:
        os.unlink(path)
    except FileNotFoundError:
        pass


def _reason(exc):
    text = str(exc).strip()
    return exc.strerror or (text.splitlines()[0] if text else type(exc).__name__)
