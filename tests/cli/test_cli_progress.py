"""Progress on long work: rich on a terminal, parseable lines when piped, off when quiet."""

import io
import json

import numpy as np
import pytest
from cli_kit import cli

from calibrator.cli import progress
from calibrator.identify import pso


class Terminal(io.StringIO):
    def isatty(self):
        return True


def parse(line):
    head, *pairs = line.split()
    assert head == "progress"
    return dict(p.split("=", 1) for p in pairs)


def test_plain_lines_are_key_value_with_eta_and_a_last_line():
    stream = io.StringIO()
    with progress.Reporter("plain", stream, interval_s=0).task("swarm", 4, "generations") as t:
        for g in range(1, 5):
            t.update(g, best=10.0 / g)
    lines = [parse(x) for x in stream.getvalue().splitlines()]
    assert [x["done"] for x in lines] == ["1", "2", "3", "4"]
    assert all(x["task"] == "swarm" and x["total"] == "4" for x in lines)
    assert all(float(x["eta_s"]) >= 0 for x in lines[:-1]) and "eta_s" not in lines[-1]
    assert float(lines[-1]["best"]) == pytest.approx(2.5) and "stopped" not in lines[-1]


def test_plain_lines_are_rate_limited():
    stream = io.StringIO()
    with progress.Reporter("plain", stream, interval_s=60).task("swarm", 1000) as t:
        for g in range(1, 1001):
            t.update(g)
    assert len(stream.getvalue().splitlines()) == 1  # only the closing line


def test_a_task_that_stops_early_says_so_and_a_failed_one_is_silent():
    stream = io.StringIO()
    with progress.Reporter("plain", stream).task("measure", 5, "poses") as t:
        t.update(3)
    assert parse(stream.getvalue())["stopped"] == "1"
    stream = io.StringIO()
    with pytest.raises(RuntimeError):
        with progress.Reporter("plain", stream).task("measure", 5, "poses") as t:
            raise RuntimeError
    assert stream.getvalue() == ""


def test_quiet_and_mode_choice():
    assert progress.Reporter.for_cli(quiet=True, stream=Terminal()).mode == "off"
    assert progress.Reporter.for_cli(stream=Terminal()).mode == "rich"
    assert progress.Reporter.for_cli(stream=io.StringIO()).mode == "plain"
    stream = io.StringIO()
    with progress.Reporter("off", stream).task("swarm", 3) as t:
        t.update(3)
    assert stream.getvalue() == ""


def test_rich_bar_on_a_terminal():
    stream = Terminal()
    with progress.Reporter("rich", stream).task("swarm", 10, "generations") as t:
        t.update(5, best=1.5)
    text = stream.getvalue()
    assert "swarm" in text and "generations" in text and "ETA" in text


def test_swarm_reports_every_generation():
    seen = []
    found = pso.ipso(
        lambda x: np.sum(x**2, axis=1),
        -np.ones(3),
        np.ones(3),
        particles=6,
        generations=25,
        on_generation=lambda g, best: seen.append((g, best)),
    )
    assert [g for g, _ in seen] == list(range(1, 26))
    np.testing.assert_array_equal([b for _, b in seen], found.history[1:])


def test_identify_shows_progress_when_piped_and_not_when_quiet(tmp_path):
    assert cli("simulate", "-o", "s.parquet", "--poses", "20", cwd=tmp_path).code == 0
    run = cli("identify", "s.parquet", "--generations", "40", "-o", "c.json", cwd=tmp_path)
    assert run.code == 0, run.stderr
    last = parse(run.stderr.strip().splitlines()[-1])
    assert last["task"] == "swarm" and last["done"] == last["total"] == "40"
    assert run.stdout.strip().splitlines()[-1].startswith("identified in ")
    curve = np.array(json.loads((tmp_path / "c.json").read_text())["solver"]["convergence"])
    assert curve[0, 0] == 0 and curve[-1, 0] == 40  # [generation, best cost] rows
    assert np.all(np.diff(curve[:, 0]) > 0) and np.all(np.diff(curve[:, 1]) <= 0)
    quiet = cli("identify", "s.parquet", "--generations", "40", "-q", "-o", "d.json", cwd=tmp_path)
    assert quiet.code == 0 and quiet.stderr == ""
