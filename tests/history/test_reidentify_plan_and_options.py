"""``history reidentify``'s plan and its option check, in-process on a real SQLite history.

Which stored sessions are identified again, which are skipped and why, what
each output is called; identify's options refused when reidentify sets them
itself, however they are spelled. Found by mutation testing (issue 44).
"""

from __future__ import annotations

import shutil

import pytest

from calibrator.history import HistoryError, open_history, reidentify

ROBOT = "sim:er10l-c10:seed=3"


def test_the_plan_skips_sessions_gone_or_changed_and_names_each_output(measured, tmp_path):
    for i in range(3):
        shutil.copy(measured / f"s{i}.parquet", tmp_path / f"s{i}.parquet")
    skipped = []
    with open_history(tmp_path / "h.sqlite") as h:
        for i in range(3):
            h.record_session(tmp_path / f"s{i}.parquet")
        digests = {s["file"]: s["sha256"] for s in h.sessions(ROBOT)}
        (tmp_path / "s1.parquet").unlink()
        (tmp_path / "s2.parquet").write_bytes(b"changed")
        jobs = reidentify.plan(h, None, tmp_path / "out", lambda f, why: skipped.append((f, why)))
        assert reidentify.plan(h, ROBOT, tmp_path / "out", lambda f, why: None) == jobs
    s0, s1, s2 = (str((tmp_path / f"s{i}.parquet").resolve()) for i in range(3))
    assert skipped == [
        (s1, "the file is not there any more"),
        (s2, "the file changed since it was recorded (SHA-256 differs)"),
    ]
    (job,) = jobs
    assert (job.robot, job.session) == (ROBOT, s0)
    assert job.output == str((tmp_path / "out").resolve() / f"s0-{digests[s0][:12]}.json")
    # An output there already is refused, not overwritten.
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / f"s0-{digests[s0][:12]}.json").write_text("{}")
    with open_history(tmp_path / "h.sqlite") as h, pytest.raises(HistoryError, match="exists"):
        reidentify.plan(h, ROBOT, tmp_path / "out", lambda f, why: None)


@pytest.mark.parametrize(
    "text", ["-o x.json", "--output=x.json", "--history=db.sqlite?mode=rw", "--like=a=b"]
)
def test_options_reidentify_sets_itself_are_refused_however_spelled(text):
    with pytest.raises(HistoryError, match=r"--identify-options: \S+ is set by reidentify"):
        reidentify.parse_options(text)


def test_other_options_are_handed_on_as_identify_reads_them():
    assert reidentify.parse_options("--method lm --seed 2") == ("--method", "lm", "--seed", "2")
    assert reidentify.parse_options("") == ()
    assert reidentify.parse_options("--note 'a b'") == ("--note", "a b")
    with pytest.raises(HistoryError, match='--identify-options "--note \'a": '):
        reidentify.parse_options("--note 'a")


def test_jobs_run_here_are_yielded_in_order_with_identifys_outcome():
    jobs = [reidentify.Job("r", f"s{i}.parquet", f"c{i}.json") for i in range(3)]
    calls = []

    def identify(session, output, options):
        calls.append((session, output, options))
        return (0, "") if session != "s1.parquet" else (2, "s1.parquet: no poses")

    done = list(reidentify.run(jobs, identify, options=("--method", "lm")))
    assert done == [(jobs[0], 0, ""), (jobs[1], 2, "s1.parquet: no poses"), (jobs[2], 0, "")]
    assert calls[1] == ("s1.parquet", "c1.json", ("--method", "lm"))


def _echo(session, output, options):
    """An identify that says what it was given (run in a Dask worker)."""
    return 0, f"{session} -> {output} {options}"


def test_jobs_sent_to_a_running_scheduler_run_on_its_cluster():
    from calibrator.analysis import engine

    jobs = [reidentify.Job("r", f"s{i}.parquet", f"c{i}.json") for i in range(2)]
    cluster = engine.local_cluster(1)
    try:
        done = list(reidentify.run(jobs, _echo, ("-q",), scheduler=cluster.scheduler_address))
        ran_here = set(cluster.scheduler.task_prefixes)
    finally:
        cluster.close()
    assert done == [
        (jobs[0], 0, "s0.parquet -> c0.json ('-q',)"),
        (jobs[1], 0, "s1.parquet -> c1.json ('-q',)"),
    ]
    assert any("echo" in prefix for prefix in ran_here), ran_here
