"""``calibrator verify --path line|circle``: the ISO 9283 path test on the simulated cell.

Parses nothing of its own (``verify`` does); runs
:mod:`calibrator.verify.path` with the simulated tracker streaming
the simulated arm's true path, writes the document with its ``path``
section and prints the figures.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import typer

from calibrator.cli._options import fail

#: Default path speed, mm/s (a tenth of a small arm's rated tool speed: ISO's 10 % case).
DEFAULT_SPEED_MM_S = 100.0


@dataclass(frozen=True)
class Speed:
    """``--path-speed``: mm/s, or a percentage of the path's rated speed."""

    value: float
    percent: bool

    def __str__(self) -> str:
        return f"{self.value:g} %" if self.percent else f"{self.value:g} mm/s"


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
    shape: str, speed: Speed, robot: str, tracker: str, world: Path | None, history: Any
) -> None:
    """Refuse, in one line each, what the path test cannot do (before anything opens)."""
    from calibrator.cli import _run
    from calibrator.verify.path import SHAPES

    if shape not in SHAPES:
        fail(f"--path must be one of {', '.join(SHAPES)}, got {shape!r}")
    if not speed.percent and not (0.0 < speed.value <= 5000.0):
        fail(f"--path-speed must be in (0, 5000] mm/s, got {speed.value:g}")
    if not (_run.is_sim(robot) and _run.is_sim(tracker)):
        fail("--path runs on the simulated cell only (--robot sim --tracker sim) for now")
    if world is not None:
        fail("--path takes the simulated cell of --seed, not --world, for now")


def run(
    *,
    shape: str,
    speed: Speed,
    arm: Any,
    vplan: Any,
    cycles: int,
    seed: int,
    tracker_url: str,
    test: Any,
    registration: Any,
    output: Path,
    inputs: list[Path],
) -> None:
    """Plan, run and write the path test; print its figures.

    ``test``: the pose test's :class:`calibrator.verify.procedure.Options`
    (tool, calibration, tracker position), whose cube the path is in.
    """
    import numpy as np

    from calibrator import outputs
    from calibrator.errors import CalibrationError
    from calibrator.model import frames
    from calibrator.simulate import SimWorld
    from calibrator.verify import path as verify_path
    from calibrator.verify import pose as pose_run
    from drivers.tracker.base import OpenOptions, open_tracker
    from drivers.tracker.line.simulator.world import SimulatedTracker

    flange2tool, calibration = frames.transform(translation=test.tool_mm), test.calibration
    world = SimWorld.make(arm.name, seed)
    if test.tracker_at_mm is not None:
        world = world.with_tracker_at(test.tracker_at_mm)
    rotation = vplan.desired[0][:3, :3]
    plan_args = (arm, flange2tool, shape, vplan.cube, rotation, vplan.q_test[0])
    # The rated speed from the nominal plan: the compensated one differs by microradians.
    rated = verify_path.rated_speed_mm_s(arm, verify_path.plan_path(*plan_args, DEFAULT_SPEED_MM_S))
    speed_mm_s = speed.value / 100.0 * rated if speed.percent else speed.value
    test = verify_path.plan_path(*plan_args, speed_mm_s, calibration)
    if registration is None:
        registration = pose_run.surveyed(world.surveyed_base2tracker(), "simulated cell survey")
    tracker = open_tracker(tracker_url, OpenOptions(world=world))
    if not isinstance(tracker, SimulatedTracker):  # check_options let only `sim` through
        raise CalibrationError(f"--path needs the simulated tracker, not {tracker_url}")
    try:
        tracker.connect()
        section, table = verify_path.run(tracker, world, test, cycles, registration.tracker2base)
    finally:
        tracker.close()
    section["rated_speed_mm_s"] = rated
    section["speed_pct"] = 100.0 * speed_mm_s / rated
    from datetime import UTC, datetime

    doc = {
        "format": pose_run.FORMAT,
        "version": pose_run.VERSION,
        "test": "path",
        "model": arm.name,
        # Who and when, as a pose test records them (the history files the test under them).
        "robot": f"sim:{world.model.name}:seed={world.seed}",
        "tracker": str(tracker.device_id or type(tracker).__name__),
        "time": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cube": vplan.cube.to_json(),
        "registration": registration.to_json(),
        "path": section,
    }
    figures = [section[k] for k in ("AT_P_mm", "RT_P_mm", "AV_pct", "RV_pct", "FV_mm_s")]
    if not np.all(np.isfinite(figures)):
        raise CalibrationError("the path test gave a non-finite figure: no document from it")
    data = pose_run.data_path(output)
    doc["data"] = data.name
    with outputs.Outputs(inputs=inputs) as batch:  # both files or neither
        batch.text(output, json.dumps(doc, indent=2, allow_nan=False) + "\n")
        batch.file(data, lambda tmp: table.to_parquet(tmp, index=False))
    state = "compensated" if test.compensated else "nominal"
    typer.echo(
        f"ISO 9283 path ({shape}, {section['commanded']['length_mm']:.1f} mm at "
        f"{speed_mm_s:.1f} mm/s, {section['speed_pct']:.0f} % of its rated {rated:.0f} mm/s), "
        f"{cycles} cycles, {state} commands, robot base frame "
        f"(registration: {registration.method})"
    )
    typer.echo(
        f"AT_P {section['AT_P_mm']:.4f} mm   RT_P {section['RT_P_mm']:.4f} mm   "
        f"AV {section['AV_pct']:+.3f} %   RV {section['RV_pct']:.3f} %   "
        f"FV {section['FV_mm_s']:.3f} mm/s"
    )
    if "CR_mm" in section:
        corners = "  ".join(
            f"C{k + 1} CR {cr:.4f} CO {co:.4f}"
            for k, (cr, co) in enumerate(zip(section["CR_mm"], section["CO_mm"], strict=True))
        )
        typer.echo(f"corners, mm (worst cycle): {corners}")
    typer.echo(f"wrote {output} and {data}")
