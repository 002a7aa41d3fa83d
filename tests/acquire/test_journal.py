"""The journal: durable lines, a lock per run, and every line validated on resume.

A journal is input like any file: a hand-edited or damaged line (a pose
outside the plan, a non-number, NaN, 1e400, stray bytes, a missing key,
joints of another pose, a changed byte caught by the line's CRC) is refused
with its line number, never trusted and never a traceback.
"""

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from timeout_kit import readline

from calibrator.acquire import journal as journals
from calibrator.acquire import rows
from calibrator.acquire.averaging import average
from drivers.tracker.line import protocol

HEADER = {"plan_sha256": "abc", "robot": "sim:r", "tracker": "t-1", "readings": 3, "poses": 4}
PLAN = np.array([np.full(6, pose / 10) for pose in range(4)])


def Reading(point):  # noqa: N802 - reads as the tracker's reading it builds
    """An accurate point reading (the tracker driver's own type)."""
    return protocol.Reading(np.asarray(point, float), None, protocol.ReadingStatus.ACCURATE, 0)


def measured(pose, x=1.0):
    avg = average([Reading([x, 2 * x, 3 * x]), Reading([x + 1, 2 * x, 3 * x])])
    return rows.measured_record(pose, PLAN[pose], avg, 1)


def failed(pose):
    return rows.failed_record(pose, "BeamBroken: beam broken", 4, {"beam broken": 4})


def test_journal_lives_beside_the_session():
    assert journals.journal_path("out/s.parquet") == journals.Path("out/s.parquet.journal")


def test_a_journal_reads_back_bit_for_bit_with_the_last_record_of_each_pose(tmp_path):
    path = tmp_path / "s.journal"
    third = measured(0, 1.0 / 3.0)
    third["point_mm"][1] = 1e-17
    with journals.Journal.create(path, HEADER) as journal:
        assert journal.path == path
        journal.append(failed(2))
        journal.append(third)
        journal.append(measured(2, 0.1))
    lines = path.read_text().split("\n")
    assert len(lines) == 5 and lines[-1] == ""  # header, three records, final newline
    head = json.loads(lines[0])
    assert head.pop("crc32") > 0 and head == {
        "format": "calibrator.journal",
        "version": 2,
        "joints": "controller",
        **HEADER,
    }
    done = journals.read(path, plan_rad=PLAN)
    assert done.header == {
        "format": "calibrator.journal",
        "version": 2,
        "joints": "controller",
        **HEADER,
    }
    assert sorted(done.records) == [0, 2] and done.records[2] == measured(2, 0.1) | {
        "timestamp": done.records[2]["timestamp"]
    }
    assert done.records[0]["point_mm"] == third["point_mm"]


def test_every_line_is_fsynced_before_the_call_returns(tmp_path, monkeypatch):
    """A crash (power cut) after append() returns must not lose that pose."""
    synced = []
    real = os.fsync

    def spy(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        real(fd)

    monkeypatch.setattr(journals.os, "fsync", spy)
    path = tmp_path / "j"
    journal = journals.Journal.create(path, HEADER)
    assert synced == [str(path), str(tmp_path)]  # the header, then the new directory entry
    journal.append(measured(0))
    assert synced == [str(path), str(tmp_path), str(path)]
    journal.close()
    journal, _ = journals.Journal.resume(path, HEADER, plan_rad=PLAN)
    journal.append(measured(1))
    journal.close()
    assert synced[-1] == str(path) and synced.count(str(path)) >= 3


def test_a_journal_is_never_replaced_and_refuses_non_finite_numbers(tmp_path):
    path = tmp_path / "j"
    journal = journals.Journal.create(path, HEADER)
    bad = measured(0)
    bad["point_mm"] = [float("nan"), 0.0, 0.0]
    with pytest.raises(ValueError):
        journal.append(bad)
    journal.close()
    journal.close()  # twice is fine
    before = path.read_bytes()
    with pytest.raises(journals.JournalError) as exc:
        journals.Journal.create(path, HEADER)
    assert str(exc.value) == (
        f"{path} exists (an unfinished run): pass --resume to continue it, or remove it to "
        "start over"
    )
    assert path.read_bytes() == before


def journal_with(tmp_path, *lines, version=2):
    """A journal whose header is valid and whose record lines are given as text."""
    path = tmp_path / "j"
    head = {"format": "calibrator.journal", "version": version, **HEADER}
    text = journals.encode_line(head, crc=version >= 2)
    path.write_bytes(text.encode() + b"".join(line + b"\n" for line in lines))
    return path


def line(record, crc=True):
    return journals.encode_line(record, crc=crc).rstrip("\n").encode()


def edited(**changes):
    record = measured(0)
    record.update(changes)
    return {k: v for k, v in record.items() if v is not ...}


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        (line(edited(pose=999)), "pose 999 is not a row of the plan"),
        (line(edited(pose=-1)), "pose -1 is not a row of the plan"),
        (line(edited(pose=True)), "pose must be a whole number, got True"),
        (line(edited(pose=1.7)), "pose must be a whole number, got 1.7"),
        (line(edited(pose="1")), "pose must be a whole number, got '1'"),
        (line(edited(status="done")), "status must be 'measured' or 'failed'"),
        (line(edited(q_rad=[0.0] * 5)), "q_rad must be 6 finite numbers"),
        (line(edited(q_rad=[0, 0, 0, 0, 0, 100])), "q_rad must be 6 finite numbers"),
        (line(edited(point_mm=[1e300, 0, 0])), "point_mm must be 3 finite numbers"),
        (line(edited(point_mm=[True, 0, 0])), "point_mm must be 3 finite numbers"),
        (line(edited(std_mm=[-1.0, 0, 0])), "std_mm must be >= 0"),
        (line(edited(n_readings=0)), "n_readings must be a whole number >= 1"),
        (line(edited(n_readings=4)), "4 readings, the run takes 3"),
        (line(edited(timestamp=...)), "timestamp must be text"),
        (line(edited(outliers=1)), "outliers must be a whole number in [0, rejected], got 1"),
        (line(edited(outliers=-1)), "outliers must be a whole number in [0, rejected]"),
        (line(edited(outliers=True)), "outliers must be a whole number in [0, rejected]"),
        (line(edited(point_mm=...)), "point_mm must be 3 finite numbers"),
        (line(edited(q_rad=[0.5] * 6)), "joints differ from the plan's row 0 by 0.5 rad"),
        (line({"pose": 1, "status": "failed", "attempts": 4}), "needs its reason"),
        (line(failed(1) | {"causes": {"x": -1}}), "causes must map a failure class"),
        (line(failed(1) | {"attempts": 0}), "attempts must be a whole number >= 1"),
        (b"[3]", "not a JSON object"),
    ],
)
def test_a_bad_record_is_refused_naming_its_line(tmp_path, raw, message):
    path = journal_with(tmp_path, line(measured(1)), raw)
    with pytest.raises(journals.JournalError, match=f"^{path}: line 3 is damaged: .*") as exc:
        journals.read(path, plan_rad=PLAN)
    assert message in str(exc.value)


def test_a_record_counts_the_outliers_its_average_set_aside_and_reads_back(tmp_path):
    still = [Reading([1.0 + 1e-3 * k, 2.0, 3.0]) for k in range(9)]
    avg = average([*still, Reading([51.0, 2.0, 3.0])])
    record = rows.measured_record(0, PLAN[0], avg, 1)
    assert (record["n_readings"], record["rejected"], record["outliers"]) == (9, 1, 1)
    with journals.Journal.create(tmp_path / "j", {**HEADER, "readings": 10}) as journal:
        journal.append(record)
    assert journals.read(tmp_path / "j", plan_rad=PLAN).records[0]["outliers"] == 1


def test_a_record_from_before_outliers_were_counted_reads_as_none_set_aside(tmp_path):
    path = journal_with(tmp_path, line(edited(outliers=...)))
    assert "outliers" not in journals.read(path, plan_rad=PLAN).records[0]


@pytest.mark.parametrize(
    "raw",
    [
        line(measured(0))[:-1] + b', "x": NaN}',  # NaN in the text (JSON has none)
        line(measured(0)).replace(b'"n_readings": 2', b'"n_readings": 1e400'),
        line(measured(0)).replace(b"measured", b"m\xffasured"),  # a stray byte
        line(measured(0)).replace(b'"attempts": 1', b'"attempts": 2'),  # CRC no longer matches
        line(measured(0), crc=False),  # no CRC in a version 2 journal
        b'{"pose": 0, "status": "meas',  # cut short, and not the last line
        b"[" * 100000,  # nested too deeply for the parser
    ],
    ids=["nan", "1e400", "stray-byte", "crc", "no-crc", "cut", "deep"],
)
def test_a_damaged_line_is_refused_naming_its_number(tmp_path, raw):
    path = journal_with(tmp_path, line(measured(1)), raw, line(measured(2)))
    with pytest.raises(journals.JournalError, match=f"^{path}: line 3 is damaged"):
        journals.read(path)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (b"", "is not a calibrator journal"),
        (b"[1, 2]\n", "is not a calibrator journal"),
        (b'{"format": "other", "version": 1}\n', "is not a calibrator journal"),
        (b'{"format": "calibrator.journal", "version": 3}\n', "journal version 3 is not supported"),
        (b'{"format": "calibrator.journal", "version": true}\n', "version True is not supported"),
        (b'{"format": "calibrator.journal"}\n', "journal version None is not supported"),
        (b'{"format": "calibrator.journal", "version": 2}\n', r"line 1 \(the header\) is damaged"),
        (b"\xff\xfe\n", "is not a calibrator journal"),
    ],
)
def test_a_bad_header_is_refused_naming_the_problem(tmp_path, text, message):
    path = tmp_path / "j"
    path.write_bytes(text)
    with pytest.raises(journals.JournalError, match=message):
        journals.read(path)


def test_a_version_1_journal_without_crcs_is_still_read(tmp_path):
    path = journal_with(tmp_path, line(measured(1), crc=False), version=1)
    assert sorted(journals.read(path, plan_rad=PLAN).records) == [1]


def test_a_missing_journal_cannot_be_resumed(tmp_path):
    with pytest.raises(journals.JournalError, match="^no journal to resume: .* not found$"):
        journals.Journal.resume(tmp_path / "none", HEADER)


@pytest.mark.parametrize("key", journals.IDENTITY_KEYS)
def test_resume_refuses_another_runs_journal(tmp_path, key):
    path = tmp_path / "j"
    journals.Journal.create(path, HEADER).close()
    other = {**HEADER, key: "other"}
    expected = f"its {key} is {HEADER[key]!r}, this run's is 'other'"
    with pytest.raises(journals.JournalError, match="belongs to another run: " + expected):
        journals.Journal.resume(path, other)


def test_resume_drops_a_line_cut_short_and_appends_after_the_last_whole_one(tmp_path):
    path = tmp_path / "j"
    first, second = measured(0), measured(1)
    with journals.Journal.create(path, HEADER) as journal:
        journal.append(first)
    with open(path, "a") as fh:
        fh.write('{"pose": 1, "status": "meas')  # a crash in the middle of a write
    journal, done = journals.Journal.resume(path, {**HEADER, "poses": 99})  # not identity
    assert sorted(done.records) == [0] and journal.path == path
    with journal:
        journal.append(second)
    assert sorted(journals.read(path).records) == [0, 1]
    records = path.read_text().split("\n")[1:]
    assert records == [line(first).decode(), line(second).decode(), ""]


HOLD = textwrap.dedent(
    """
    import sys, time
    from calibrator.acquire import journal as journals
    header = dict(plan_sha256="abc", robot="sim:r", tracker="t-1", readings=3, poses=4)
    journal, _ = journals.Journal.resume(sys.argv[1], header)
    print("locked", flush=True)
    time.sleep(60)
    """
)


def test_a_journal_in_use_by_another_run_cannot_be_resumed(tmp_path):
    path = tmp_path / "j"
    with journals.Journal.create(path, HEADER) as journal:
        journal.append(measured(0))
        with pytest.raises(journals.JournalError, match="is in use by another measure run"):
            journals.Journal.resume(path, HEADER)  # while its creator still writes it
    holder = subprocess.Popen([sys.executable, "-c", HOLD, str(path)], stdout=subprocess.PIPE)
    try:
        assert readline(holder.stdout, what="'locked'") == b"locked\n"
        before = path.read_bytes()
        with pytest.raises(journals.JournalError) as exc:
            journals.Journal.resume(path, HEADER)
        assert str(exc.value) == (
            f"{path} is in use by another measure run: wait for it to end (or stop it), then resume"
        )
        assert path.read_bytes() == before
    finally:
        holder.kill()
        holder.wait(10)
    journal, done = journals.Journal.resume(path, HEADER)  # the lock went with the process
    journal.close()
    assert sorted(done.records) == [0]


def test_an_integer_beyond_64_bits_is_not_read(tmp_path):
    # The strict JSON reader refuses it before any record check sees it.
    path = journal_with(tmp_path, line(measured(1)), line(edited(attempts=10**400)))
    with pytest.raises(journals.JournalError, match=f"^{path}: line 3 is damaged \\(not JSON"):
        journals.read(path, plan_rad=PLAN)


def test_a_journal_holds_the_controllers_angles_and_gives_back_the_models(tmp_path):
    from calibrator import robots

    kuka = robots.get("kuka-kr6-r900").convention
    path = tmp_path / "j"
    with journals.Journal.create(path, HEADER, kuka) as journal:
        journal.append(measured(2))
    lines = path.read_text().splitlines()
    assert json.loads(lines[0])["joints"] == "controller"
    written = np.array(json.loads(lines[1])["q_rad"])
    # The record's model angles are 0.2 on every joint: the line says A1 and A6 mirrored.
    np.testing.assert_allclose(written, kuka.to_controller(PLAN[2]))
    assert written[0] == -0.2 and written[5] == -0.2
    done = journals.read(path, plan_rad=PLAN, convention=kuka)
    np.testing.assert_allclose(done.records[2]["q_rad"], PLAN[2], atol=1e-15)
    # Read without the arm's convention, the controller's angles are not the plan's joints.
    with pytest.raises(journals.JournalError, match="joints differ from the plan's row 2"):
        journals.read(path, plan_rad=PLAN)


def test_a_journal_from_before_the_joints_key_is_read_in_the_models_angles(tmp_path):
    from calibrator import robots

    kuka = robots.get("kuka-kr6-r900").convention
    path = tmp_path / "j"
    lines = [
        json.dumps({"format": journals.FORMAT, "version": 1, **HEADER}),
        json.dumps(measured(1)),
    ]
    path.write_text("\n".join(lines) + "\n")
    done = journals.read(path, plan_rad=PLAN, convention=kuka)
    np.testing.assert_array_equal(done.records[1]["q_rad"], PLAN[1])
