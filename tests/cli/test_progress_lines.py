"""Progress lines, exactly: a clock the test moves, every line and field checked."""

import io
import re
import sys
from types import SimpleNamespace

import pytest

from calibrator.cli import progress


class Clock:
    """Stands in for ``time`` in calibrator.cli.progress: the test sets the time."""

    def __init__(self):
        self.now = 100.0

    def monotonic(self):
        return self.now


# One frame of the bar: name, bar, count, unit, elapsed time, ETA, extra fields.
FRAME = re.compile(
    r"^swarm [━╸╺]+ +(?P<count>\d+)/10 generations \d:\d\d:\d\d "
    r"ETA (-:--:--|\d:\d\d:\d\d) ?(?P<info>.*)$"
)


class Terminal(io.StringIO):
    def isatty(self):
        return True


@pytest.fixture
def clock(monkeypatch):
    clock = Clock()
    monkeypatch.setattr(progress, "time", SimpleNamespace(monotonic=clock.monotonic))
    return clock


def test_plain_lines_at_the_interval_and_a_last_line(clock):
    stream = io.StringIO()
    reporter = progress.Reporter("plain", stream, interval_s=2.0)
    with reporter.task("swarm", 8, "generations") as task:
        clock.now = 101.0
        task.update(1, best=4.0)  # 1 s after the start: too early
        clock.now = 102.0
        task.update(2, best=0.5)  # exactly the interval: shown
        clock.now = 103.5
        task.update(3, best=0.25)  # 1.5 s after the last line
        clock.now = 104.0
        task.update(4, best=0.125, phase="fit all")
        clock.now = 110.0
        task.update(8, best=0.0625)  # done: the closing line says it
    assert stream.getvalue().splitlines() == [
        "progress task=swarm done=2 total=8 unit=generations elapsed_s=2.00 eta_s=6.00 best=0.5",
        "progress task=swarm done=4 total=8 unit=generations elapsed_s=4.00 eta_s=4.00 "
        "best=0.125 phase=fit_all",
        "progress task=swarm done=8 total=8 unit=generations elapsed_s=10.00 "
        "best=0.0625 phase=fit_all",
    ]


def test_the_default_interval_is_two_seconds(clock):
    stream = io.StringIO()
    with progress.Reporter("plain", stream).task("measure", 10, "poses") as task:
        clock.now = 101.99
        task.update(1)
        assert stream.getvalue() == ""
        clock.now = 102.0
        task.update(2)
        assert stream.getvalue() == (
            "progress task=measure done=2 total=10 unit=poses elapsed_s=2.00 eta_s=8.00\n"
        )


def test_a_task_that_stops_early_has_no_eta_and_says_stopped(clock):
    stream = io.StringIO()
    with progress.Reporter("plain", stream, interval_s=0).task("measure", 5.0, "poses") as task:
        clock.now = 103.0
        task.update(3.0, lost=1)
        stream.seek(0)
        stream.truncate()
    assert stream.getvalue() == (
        "progress task=measure done=3 total=5 unit=poses elapsed_s=3.00 lost=1 stopped=1\n"
    )


def test_no_eta_before_the_first_unit_and_default_unit(clock):
    stream = io.StringIO()
    with progress.Reporter("plain", stream, interval_s=0).task("load", 3) as task:
        clock.now = 100.5
        task.update(0)
        task.update(-1)
    assert stream.getvalue().splitlines() == [
        "progress task=load done=0 total=3 unit=steps elapsed_s=0.50",
        "progress task=load done=-1 total=3 unit=steps elapsed_s=0.50",
        "progress task=load done=-1 total=3 unit=steps elapsed_s=0.50 stopped=1",
    ]


def test_a_failed_task_writes_no_closing_line(clock):
    stream = io.StringIO()
    with pytest.raises(KeyError):
        with progress.Reporter("plain", stream, interval_s=60).task("swarm", 4) as task:
            task.update(2)
            raise KeyError("x")
    assert stream.getvalue() == ""


def test_quiet_writes_nothing_whatever_happens(clock):
    stream = Terminal()
    reporter = progress.Reporter.for_cli(quiet=True, stream=stream)
    with reporter.task("swarm", 4) as task:
        for done in range(1, 3):
            clock.now += 10
            task.update(done, best=1.0)
    assert stream.getvalue() == ""
    assert task.done == 2 and task.fields == {"best": 1.0}


def test_field_formats():
    assert progress._fmt(0.1234567891) == "0.123457"
    assert progress._fmt(1234567.0) == "1.23457e+06"
    assert progress._fmt(3) == "3"
    assert progress._fmt("two words here") == "two_words_here"
    assert progress._fmt(True) == "True"


def test_reporter_defaults_and_bad_mode(capsys):
    reporter = progress.Reporter()
    assert (reporter.mode, reporter.stream, reporter.interval_s) == ("plain", sys.stderr, 2.0)
    assert progress.Reporter.for_cli().stream is sys.stderr
    with pytest.raises(ValueError, match=r"progress mode must be one of .*'loud'"):
        progress.Reporter("loud")
    no_tty = SimpleNamespace()  # a stream without isatty counts as not a terminal
    assert progress.Reporter.for_cli(stream=no_tty).mode == "plain"
    assert progress.Reporter.for_cli(stream=Terminal()).mode == "rich"
    assert progress.Reporter.for_cli(quiet=True).mode == "off"
    for quiet in (True, False):
        stream = io.StringIO()
        assert progress.Reporter.for_cli(quiet, stream).stream is stream


def test_rich_bar_is_fed_at_most_twenty_times_a_second_and_shows_the_last_count(clock):
    stream = Terminal()
    clock.now = 0.0  # 0.05 - 0.0 is exactly 0.05 in binary, 100.05 - 100.0 is not
    with progress.Reporter("rich", stream).task("swarm", 10, "generations") as task:
        bar = task._bar.tasks[0]
        assert (bar.description, bar.total, bar.completed) == ("swarm", 10, 0)
        clock.now = 0.04
        task.update(3, best=2.5)
        assert bar.completed == 0  # too soon after the start
        clock.now = 0.05
        task.update(4, best=1.5, phase="fit")
        assert bar.completed == 4
        assert bar.fields["info"] == "best 1.5  phase fit"
        clock.now = 0.06
        task.update(6, best=1.25)
        assert bar.completed == 4
    assert bar.completed == 6 and bar.fields["info"] == "best 1.25  phase fit"
    assert not task._bar.live.is_started
    # What the terminal showed, frame by frame (colours removed), then erased.
    text = stream.getvalue()
    assert text.endswith("\x1b[1A\x1b[2K")  # the bar leaves no trace when done
    frames = [re.sub(r"\x1b\[[0-9;?]*[a-zA-Z]", "", f) for f in text.split("\r\x1b[2K")[1:]]
    shown = [FRAME.match(f.strip()) for f in frames]
    assert all(shown), frames
    assert shown[0].group("count", "info") == ("0", "")
    assert shown[-1].group("count", "info") == ("6", "best 1.25  phase fit")


def test_a_failed_rich_task_stops_its_bar(clock):
    stream = Terminal()
    with pytest.raises(RuntimeError):
        with progress.Reporter("rich", stream).task("swarm", 10) as task:
            raise RuntimeError
    assert not task._bar.live.is_started


def test_a_task_never_updated_closes_with_nothing_done(clock):
    stream = io.StringIO()
    with progress.Reporter("plain", stream).task("plan", 2) as task:
        assert (task.done, task.fields) == (0, {})
    assert stream.getvalue() == (
        "progress task=plan done=0 total=2 unit=steps elapsed_s=0.00 stopped=1\n"
    )


class Pipe(io.StringIO):
    """A stream that counts flushes: a line piped to another program must go out at once."""

    flushes = 0

    def flush(self):
        self.flushes += 1
        super().flush()


def test_each_line_is_flushed_and_the_first_unit_already_has_an_eta(clock):
    stream = Pipe()
    with progress.Reporter("plain", stream, interval_s=0).task("swarm", 4) as task:
        clock.now = 101.0
        task.update(1)
        assert stream.getvalue().splitlines() == [
            "progress task=swarm done=1 total=4 unit=steps elapsed_s=1.00 eta_s=3.00"
        ]
        assert stream.flushes == 1
    assert stream.flushes == 2
