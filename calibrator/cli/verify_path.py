"""``calibrator verify --path line|circle|rectangle``: the ISO 9283 path test.

Reads ``--path-speed``, refuses what the test cannot do before anything
opens, runs the procedure (:mod:`calibrator.verify.path_procedure`: the
robot runs the path while the tracker streams it; it writes the document)
and prints the figures.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import typer

from calibrator.cli._options import fail
from calibrator.verify.path_procedure import Speed

#: Robot kinds (``--robot`` URL schemes) whose drivers run a timed path themselves.
PATH_ROBOT_KINDS = frozenset({"sim", "ur"})

__all__ = ["Speed", "check_options", "parse_speed", "run"]


def parse_speed(text: str) -> Speed:
    """``--path-speed`` read: ``400`` (mm/s) or ``50%`` (of the rated speed); exit 2 otherwise."""
    from calibrator.inputs.grammar import StrictError, parse_number

    raw = str(text).strip()
    percent = raw.endswith("%")
    body = raw[:-1].strip() if percent else raw
    try:
        value = parse_number(body, "--path-speed")
    except StrictError:
        fail(f"--path-speed must be mm/s or a percentage such as 50%, got {text!r}")
    if percent and not (0.0 < value <= 100.0):
        fail(f"--path-speed must be in (0, 100] % of the rated speed, got {value:g} %")
    return Speed(value, percent)


def check_options(
    shape: str,
    speed: Speed,
    robot: str,
    tracker: str,
    world: Path | None,
    history: Any,
) -> None:
    """Refuse, in one line each, what the path test cannot do (before anything opens)."""
    from calibrator.cli import _run
    from calibrator.verify.path import SHAPES

    if shape not in SHAPES:
        fail(f"--path must be one of {', '.join(SHAPES)}, got {shape!r}")
    if not speed.percent and not (0.0 < speed.value <= 5000.0):
        fail(f"--path-speed must be in (0, 5000] mm/s, got {speed.value:g}")
    if robot == "external":
        if _run.is_sim(tracker):
            fail(
                "--robot external --path watches a tracker the arm's program moves: give "
                "--tracker URL (a real tracker, or a tracker simulator the external-robot "
                "simulator steers; docs/verify.md)"
            )
    elif not (_run.is_sim(robot) or _run.kind(robot) in PATH_ROBOT_KINDS):
        fail(
            "--path runs with the simulated arm or a UR (--robot sim or ur://HOST), or on an "
            "arm running `calibrator program --path` (--robot external --tracker URL)"
        )
    if world is not None:
        fail("--path takes the simulated cell of --seed, not --world, for now")
    if robot == "external" and speed.percent:
        fail(
            "--robot external --path: give the mm/s `calibrator program --path` printed "
            "(the program states it), not a percentage"
        )


def run(
    *,
    shape: str,
    speed: Speed,
    arm: Any,
    cycles: int,
    options: Any,
    devices: Any,
    output: Path,
    inputs: list[Path],
    yes: bool = False,
) -> None:
    """Run the path test procedure (:mod:`calibrator.verify.path_procedure`); print its figures.

    ``options``: the pose test's :class:`calibrator.verify.procedure.Options`
    (cube, tool, calibration, registration, tracker position, seed).
    """
    from calibrator.verify import path_procedure as path_test
    from calibrator.verify.path import ORIENTATION_FIGURES

    def confirm(robot_id: str) -> None:
        what = f"the robot {robot_id} would run the {shape} {cycles} times at {speed}"
        if not sys.stdin.isatty():
            fail(f"{what}: pass --yes to confirm")
        if not typer.confirm(f"{what[0].upper()}{what[1:]}: go?", default=False):
            fail("not confirmed; nothing moved")

    from calibrator.acquire.ports import RobotHalted

    say = lambda text: typer.echo(text, err=True)  # noqa: E731  the operator's cue

    try:
        result = path_test.run(
            arm,
            path_test.Options(shape, speed, cycles, options, say=say),
            output,
            devices,
            inputs=inputs,
            confirm=None if yes else confirm,
        )
    except RobotHalted as exc:  # a stop mid-path (a UR): as the pose test's, exit 1
        typer.echo(
            f"stopped: the robot halted during the path test ({exc}); nothing written: "
            "clear the stop and run it again (a path test is not resumed)",
            err=True,
        )
        raise typer.Exit(1) from None
    section, speed_mm_s, rated = result.document["path"], result.speed_mm_s, result.rated_mm_s
    state = "compensated" if result.compensated else "nominal"
    typer.echo(
        f"ISO 9283 path ({shape}, {section['commanded']['length_mm']:.1f} mm at "
        f"{speed_mm_s:.1f} mm/s, {section['speed_pct']:.0f} % of its rated {rated:.0f} mm/s), "
        f"{cycles} cycles, {state} commands, robot base frame "
        f"(registration: {result.registration.method})"
    )
    typer.echo(
        f"AT_P {section['AT_P_mm']:.4f} mm   RT_P {section['RT_P_mm']:.4f} mm   "
        f"AV {section['AV_pct']:+.3f} %   RV {section['RV_pct']:.3f} %   "
        f"FV {section['FV_mm_s']:.3f} mm/s"
    )
    if section.get("ATa_deg") is not None:  # a 6-DoF probe's orientation figures
        typer.echo(
            "orientation, deg: "
            + "   ".join(f"{k[:2]}_{k[2]} {section[k]:.4f}" for k in ORIENTATION_FIGURES)
        )
    if "CR_mm" in section:
        corners = "  ".join(
            f"C{k + 1} CR {cr:.4f} CO {co:.4f}"
            for k, (cr, co) in enumerate(zip(section["CR_mm"], section["CO_mm"], strict=True))
        )
        typer.echo(f"corners, mm (worst cycle): {corners}")
    typer.echo(f"wrote {output} and {result.data}")
