"""A plan checked against guessed capsules says so: on the terminal, in its file, in measure.

A URDF whose collision meshes are missing (or that has no collision
geometry) gets capsules drawn along its links between the joints: a guess
of the arm's shape. ``plan`` checked every pose and move against that guess
without a word (issue #39).
"""

import csv
import os
import shutil
import sys
from pathlib import Path

import pytest
import typer
from cli_kit import cli

from calibrator import planning, robots
from calibrator.cli import _run

DATA = Path(robots.__file__).with_name("data")
#: The shipped KUKA KR 6 R900 URDF: joints only, no collision geometry.
KUKA = (DATA / "kuka-kr6-r900.urdf").read_text()
MISSING = "package://kuka_kr6_support/meshes/collision/link_2.stl"


def _rows(path):
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_a_urdf_with_a_missing_mesh_plans_with_its_guess_said_and_recorded(tmp_path):
    collision = f'<link name="link_2"><collision><geometry><mesh filename="{MISSING}"/></geometry>'
    (tmp_path / "arm.urdf").write_text(
        KUKA.replace('<link name="link_2"/>', collision + "</collision></link>")
    )
    done = cli("plan", "--model", "arm.urdf", "--poses", "12", "-o", "p.csv", cwd=tmp_path)
    assert done.code == 0, done.stderr
    guess = (
        "links 1, 2, 3, 4, 5, 6 are capsules drawn along the joints: collision meshes not "
        f"found ({MISSING})"
    )
    assert f"warning: guessed geometry: {guess}; every pose and move was checked" in done.stderr
    # In the file, on every row (the joints stay the last six columns), and read back.
    rows = _rows(tmp_path / "p.csv")
    assert {r["geometry"] for r in rows} == {f"guessed: {guess}"}
    assert list(rows[0])[-8:] == ["geometry", "joints", *planning.JOINT_COLUMNS]
    assert planning.read_plan(tmp_path / "p.csv").origin.guessed_geometry == guess


def test_a_urdf_without_collision_geometry_is_a_guess_too_and_measure_says_so(tmp_path):
    shutil.copy(DATA / "kuka-kr6-r900.urdf", tmp_path / "kuka.urdf")
    done = cli("plan", "--model", "kuka.urdf", "--poses", "12", "-o", "p.csv", cwd=tmp_path)
    assert done.code == 0, done.stderr
    guess = "links 1, 2, 3, 4, 5, 6 are capsules drawn along the joints: no collision geometry"
    assert f"warning: guessed geometry: {guess}" in done.stderr
    measured = cli(
        "measure", "-q", "--model", "kuka.urdf", "--plan", "p.csv", "-o", "s.parquet",
        cwd=tmp_path,
    )  # fmt: skip
    assert measured.code == 0, measured.stderr
    # The simulated arm asks nothing: said as a warning.
    assert f"warning: every pose and move checked against guessed geometry: {guess}" in (
        measured.stderr
    )


def test_a_plan_fitted_to_the_arms_geometry_says_nothing_of_guesses(tmp_path):
    done = cli("plan", "--poses", "12", "--tracker-at", "2500,400,300", "-o", "p.csv", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "guess" not in done.stderr
    assert "geometry" not in _rows(tmp_path / "p.csv")[0]
    assert planning.read_plan(tmp_path / "p.csv").origin.guessed_geometry is None
    assert planning.guessed_geometry(robots.get("ur10e")) is None


GUESS = "links 1, 2 are capsules drawn along the joints: no collision geometry"


def test_the_confirmation_before_a_real_robot_moves_names_the_guess(monkeypatch):
    class Terminal:
        def isatty(self):
            return True

    monkeypatch.setattr(sys, "stdin", Terminal())
    asked = []
    monkeypatch.setattr(typer, "confirm", lambda text, default: asked.append(text) or True)
    _run.confirm("ur://h:arm", 3, GUESS)
    assert asked == [f"Move the robot ur://h:arm through 3 poses checked against guessed geometry "
                     f"({GUESS})?"]  # fmt: skip


def test_without_a_terminal_the_refusal_names_the_guess(monkeypatch, capsys):
    monkeypatch.setattr(sys, "stdin", open(os.devnull))  # not a terminal
    with pytest.raises(typer.Exit) as exc:
        _run.confirm("ur://h:arm", 3, GUESS)
    assert exc.value.exit_code == 2
    assert capsys.readouterr().err == (
        f"calibrator: error: the robot ur://h:arm would move through 3 poses checked against "
        f"guessed geometry ({GUESS}): pass --yes to confirm\n"
    )
