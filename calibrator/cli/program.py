"""``calibrator program``: the plan as a robot program for any controller (``--robot external``)."""

from __future__ import annotations

import re
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli import _run
from calibrator.cli._app import app
from calibrator.cli._options import fail
from calibrator.program import REGISTRY

#: The ``--format`` choices, generated from the writer registry.
# mypy cannot type a functional Enum whose members come from a registry at run time.
ProgramFormat = StrEnum("ProgramFormat", {name: name for name in REGISTRY})  # type: ignore[misc]
_FORMAT_HELP = "Program language [default: from the output's extension]. " + "; ".join(
    f"{f.name}: {f.help}" for f in REGISTRY.values()
)


@app.command()
def program(
    plan_path: Path = typer.Argument(..., metavar="PLAN", help="Plan CSV (calibrator plan)."),
    output: Path = opts.output(..., "Program file to write."),
    force: bool = opts.force(),
    fmt: ProgramFormat = typer.Option(None, "--format", help=_FORMAT_HELP),
    model: str = opts.model(help="Named model (joint limits, speed ceiling)."),
    speed: float = _run.speed_option(None, "[default: the model's fixed ceiling; only lower]"),
    accel: float = _run.accel_option(None, "[default: the model's ceiling; only lower]"),
    dwell: float = opts.positive(
        2.0, "Wait at each pose, s: more than the settle window plus the readings' time."
    ),
    pulse: int = typer.Option(
        None, callback=checks.at_least(0), help="Digital output pulsed at each arrival."
    ),
    home: str = typer.Option(
        None,
        help="Safe start and end pose J1,...,J6 in degrees [default: the plan's first pose].",
    ),
) -> None:
    """Write the plan as a robot program: home, a joint move and a dwell per pose, home.

    Via rows of the plan become joint moves without dwell or pulse before their pose.
    """
    import numpy as np

    from calibrator import outputs
    from calibrator import plan as plans
    from calibrator import program as programs
    from calibrator.models import get_model

    chosen = programs.choose(None if fmt is None else fmt.value, output)
    outputs.check(output, inputs=[plan_path], force=force)
    arm = get_model(model)
    given = plans.read_plan(plan_path)
    q = plans.validate(given.q_rad, arm.joint_limits_rad)
    # Vias too: the controller moves through them on the path the plan checked.
    plans.validate(given.path_rad, arm.joint_limits_rad)
    speed = arm.move_speed_cap_rad_s if speed is None else speed
    accel = arm.move_accel_cap_rad_s2 if accel is None else accel
    if speed > arm.move_speed_cap_rad_s:
        fail(f"--speed {speed} rad/s above the {arm.name} ceiling {arm.move_speed_cap_rad_s}")
    if accel > arm.move_accel_cap_rad_s2:
        fail(f"--accel {accel} rad/s^2 above the {arm.name} ceiling {arm.move_accel_cap_rad_s2}")
    home_rad = q[0] if home is None else np.radians(_degrees(home))
    plans.validate(home_rad[None], arm.joint_limits_rad)
    # KRL and Fanuc want the program named as its file.
    stem = re.sub(r"\W", "_", output.name.split(".")[0]) or "calibrator_measure"
    name = stem if stem[0].isalpha() else f"p_{stem}"
    spec = programs.ProgramSpec(
        plan_rad=q,
        home_rad=home_rad,
        speed_rad_s=speed,
        accel_rad_s2=accel,
        max_joint_speed_rad_s=arm.max_joint_speed_rad_s,
        dwell_s=dwell,
        pulse_output=pulse,
        name=name,
        model=arm.name,
        via_rad=given.via_rad,
    )
    outputs.write_text(output, programs.render(spec, chosen), inputs=[plan_path])
    typer.echo(
        f"wrote {output} ({chosen}): {len(q)} poses"
        + (f" and {given.n_vias} vias" if given.n_vias else "")
        + f", {speed:g} rad/s, {dwell:g} s dwell; "
        f"measure with --robot external --plan {plan_path}"
    )


def _degrees(text: str) -> list[float]:
    """``--home J1,...,J6`` (deg) to six finite floats (exit 2 otherwise)."""
    return opts.floats(text, 6, "--home", "six joint angles J1,...,J6 in degrees")
