"""The journal reaches the disk before the robot moves on: checked on the system calls themselves.

A power cut after ``append`` returns must not lose that pose, so each line
must be followed by an ``fsync`` of the journal before the next line or the
return; a new journal's directory entry and the cut of a torn last line on
resume must be synced too. A crash of the process alone cannot show a missing
``fsync`` (the kernel still holds the data), so the journal is written in a
child process under ``strace``, which records the calls the kernel actually
received.
"""

import os
import re
import shutil
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(shutil.which("strace") is None, reason="needs strace")

WRITER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from calibrator.acquire import journal as journals, rows
    from calibrator.acquire.averaging import average
    from drivers.tracker.line.protocol import Reading as TrackerReading, ReadingStatus

    def Reading(point):
        return TrackerReading(np.asarray(point, float), None, ReadingStatus.ACCURATE, 0)

    header = {"plan_sha256": "abc", "robot": "sim:r", "tracker": "t-1", "readings": 2, "poses": 3}
    plan = np.array([np.full(6, pose / 10) for pose in range(3)])

    def record(pose):
        avg = average([Reading([pose, 2.0, 3.0]), Reading([pose + 1.0, 2.0, 3.0])])
        return rows.measured_record(pose, plan[pose], avg, 1)

    path, step = sys.argv[1], sys.argv[2]
    if step == "create":
        with journals.Journal.create(path, header) as journal:
            journal.append(record(0))
            journal.append(record(1))
    else:
        journal, _ = journals.Journal.resume(path, header, plan_rad=plan)
        journal.append(record(2))
        journal.close()
    """
)


def traced_calls(tmp_path, journal, step):
    """The write, fsync and ftruncate calls on the journal and its folder, in order.

    Each item is ``(call, target)`` with target ``"journal"`` or ``"folder"``.
    """
    log = tmp_path / f"{step}.strace"
    command = ["strace", "-f", "-y", "-qq", "-o", str(log)]
    command += ["-e", "trace=write,fsync,fdatasync,ftruncate", sys.executable, "-c", WRITER]
    done = subprocess.run(
        [*command, str(journal), step], capture_output=True, text=True, timeout=120, cwd=tmp_path
    )
    if done.returncode != 0 and "ptrace" in done.stderr:
        pytest.skip(f"strace cannot trace here: {done.stderr.strip()[-200:]}")
    assert done.returncode == 0, done.stderr
    calls = []
    for line in log.read_text().splitlines():
        match = re.search(r"(write|fsync|fdatasync|ftruncate)\(\d+<([^>]*)>", line)
        if match is None:
            continue
        target = match.group(2)
        if target == os.fspath(journal):
            calls.append((match.group(1), "journal"))
        elif target == os.fspath(journal.parent):
            calls.append((match.group(1), "folder"))
    return calls


def test_every_journal_line_is_synced_before_the_next_one_and_the_folder_too(tmp_path):
    journal = tmp_path / "s.journal"
    calls = traced_calls(tmp_path, journal, "create")
    synced = [call if call[0] != "fdatasync" else ("fsync", call[1]) for call in calls]
    # header, then its directory entry, then one synced line per pose
    assert synced == [
        ("write", "journal"),
        ("fsync", "journal"),
        ("fsync", "folder"),
        ("write", "journal"),
        ("fsync", "journal"),
        ("write", "journal"),
        ("fsync", "journal"),
    ]
    assert len(journal.read_text().splitlines()) == 3


def test_a_torn_last_line_is_cut_durably_before_resuming(tmp_path):
    journal = tmp_path / "s.journal"
    traced_calls(tmp_path, journal, "create")
    whole = journal.read_bytes()
    journal.write_bytes(whole + b'{"pose": 2, "po')  # a write a power cut interrupted
    calls = traced_calls(tmp_path, journal, "resume")
    cut = calls.index(("ftruncate", "journal"))
    assert calls[cut + 1] == ("fsync", "journal")  # the cut is on disk before any new line
    assert calls[cut + 2 :] == [("write", "journal"), ("fsync", "journal")]
    assert journal.read_bytes().startswith(whole) and journal.read_bytes().count(b"\n") == 4
