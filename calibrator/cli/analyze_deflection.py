"""``calibrator analyze deflection``: hand error from link bending (Chen and Zhang, 1984)."""

import json
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import analyze_app
from calibrator.errors import CalibrationError
from calibrator.inputs.rules import Rule
from calibrator.recorded_options import RULES

_DEG = 3.141592653589793 / 180.0
#: A motion's time: below 10 ms its accelerations are not a robot's (1e-300 s
#: made them overflow to nan); above an hour it is not one motion.
_DURATION = Rule("duration", float, 0.01, 3600.0, unit="s", meaning="motion time")
#: Share of the time accelerating: below 1 % the accelerations overflow (5e-324 gave nan).
_RAMP = Rule("ramp", float, 0.01, 0.5, meaning="share of the time accelerating")


def _vector(text: str, what: str, prismatic: list[bool], limits) -> list[float]:
    """Joint values from the command line (deg, or mm for prismatic joints), within ``limits``.

    ``limits`` (n, 2) are in rad (mm for prismatic joints); a value beyond
    them is refused naming the joint (the model would be evaluated where the
    arm cannot go, or at 1e308 degrees).
    """
    n = len(prismatic)
    values = opts.floats(text, n, what, f"{n} comma-separated numbers (deg, or mm if prismatic)")
    out = []
    for j, (v, p, (low, high)) in enumerate(zip(values, prismatic, limits, strict=True)):
        unit, scale = ("mm", 1.0) if p else ("deg", _DEG)
        if not low <= v * scale <= high:
            opts.fail(
                f"{what}: joint {j + 1} at {v:g} {unit} is beyond its limits "
                f"[{low / scale:g}, {high / scale:g}] {unit}"
            )
        out.append(v * scale)
    return out


def _direction(vector_mm, size_mm: float) -> str:
    """The unit direction of a deflection, ``(+0.99, -0.10, +0.00)``, or "(none)" for zero."""
    if not size_mm > 0:
        return "(none)"
    return "(" + ", ".join(f"{v / size_mm:+.2f}" for v in vector_mm) + ")"


#: Old spellings of ``--model paper``, still accepted: the project once called
#: its source papers "seeds", a word that now means only the random seed.
PAPER_ALIASES = ("seed",)


@analyze_app.command("deflection")
@opts.urdf_links
def deflection(
    model: str = opts.model(
        "paper",
        "'paper' (the five-axis example of the deflection paper, Chen and Zhang 1984; "
        "'seed' is its old spelling) or a named model with --sections.",
    ),
    sections: Path = typer.Option(
        None, help="Link-section YAML (flexible links, diameters, material); named models only."
    ),
    masses: str = typer.Option(
        None,
        callback=checks.rule(RULES["mass_model"]),
        help="Mass model: a named arm or a YAML file [default: the model's published one].",
    ),
    start: str = typer.Option(
        None, help="Trajectory start, joint values (deg; mm for prismatic) [paper: its task]."
    ),
    pose: str = typer.Option(
        None, help="End pose, joint values (deg; mm for prismatic) [paper: its task's end]."
    ),
    duration: float = typer.Option(
        1.0,
        callback=checks.rule(_DURATION),
        help="Motion time (s, 0.01..3600).",
    ),
    ramp: float = typer.Option(
        0.25,
        callback=checks.rule(_RAMP),
        help="Share of the time spent accelerating (and decelerating), in [0.01, 0.5].",
    ),
    samples: int = typer.Option(
        201,
        callback=checks.count("trajectory_samples", 3),
        help="Trajectory samples (3..20000).",
    ),
    payload_kg: float = typer.Option(
        0.0,
        callback=checks.rule(RULES["payload_kg"]),
        help="Payload at the hand (kg, 0..100), named models.",
    ),
    plot: Path = typer.Option(None, help="Write a deflection map of the workspace (PNG)."),
    json_out: Path = typer.Option(None, "--json", help="Write the results to this JSON file."),
    force: bool = opts.force(),
) -> None:
    """Link bending by kinetostatics: hand deflection at the end pose and along a motion."""
    import numpy as np

    from calibrator import outputs, robots
    from calibrator.analysis import deflection as dfl
    from calibrator.robots import masses as arm_masses

    if plot is not None and plot.suffix.lower() != ".png":
        # The map is a PNG: a file named .txt (or .json) holding one would deceive.
        raise CalibrationError(
            f"--plot {outputs.show(plot)}: the map is a PNG; end the name in .png"
        )
    for path, option in ((json_out, "--json"), (plot, "--plot")):
        if path is not None:
            outputs.check(path, inputs=[sections], force=force, option=option)
    paper = model.strip().lower() in ("paper", *PAPER_ALIASES)
    if paper:
        model = "paper"  # recorded under its name, whichever spelling was typed
        if sections is not None or masses is not None or payload_kg:
            raise CalibrationError(
                "--sections, --masses and --payload-kg apply to named models; "
                "the paper's example has its own"
            )
        arm = dfl.paper_arm()
        prismatic = list(dfl.PAPER_PRISMATIC)
        q, dt = dfl.paper_trajectory(samples, ramp)
        if duration != dfl.PAPER_DURATION_S:
            dt *= duration / dfl.PAPER_DURATION_S
        if start is not None or pose is not None:
            limits = dfl.PAPER_LIMITS
            q0 = q[0] if start is None else np.array(_vector(start, "--start", prismatic, limits))
            q1 = q[-1] if pose is None else np.array(_vector(pose, "--pose", prismatic, limits))
            q, dt = dfl.trapezoid(q0, q1, duration, samples, ramp)
        map_joints, map_ranges = (1, 2), ((-30 * _DEG, 30 * _DEG), (300.0, 800.0))
    else:
        if sections is None:
            raise CalibrationError(f"--model {model}: give --sections (a link-section YAML)")
        table, from_file = dfl.load_sections(sections)
        if masses is None and from_file is not None and not _is_path(from_file):
            # The sections' mass model names another arm: its masses would load
            # this arm's links without a word. Taking them is the user's choice.
            theirs, ours = robots.get(from_file).name, robots.get(model).name
            if theirs != ours:
                raise CalibrationError(
                    f"--sections {outputs.show(sections)}: its mass_model is the {theirs}'s, "
                    f"not --model {model}'s; give --masses {from_file} to use it anyway"
                )
        source = masses or from_file or model
        arm = dfl.named_arm(model, table, arm_masses.resolve(source))
        prismatic = [False] * 6
        limits = robots.get(model).joint_limits_rad
        q0 = (
            np.zeros(6) if start is None else np.array(_vector(start, "--start", prismatic, limits))
        )
        q1 = np.zeros(6) if pose is None else np.array(_vector(pose, "--pose", prismatic, limits))
        q, dt = dfl.trapezoid(q0, q1, duration, samples, ramp)
        map_joints, map_ranges = (1, 2), ((-np.pi, 0.0), (-np.pi * 0.9, np.pi * 0.9))
    static = dfl.deflect(arm, q[-1:], payload_kg=payload_kg)
    moving = dfl.deflect(arm, q, dt, payload_kg=payload_kg)
    n = arm.n
    dz_end = float(static.hand_mm[0, 2])
    zs = moving.hand_mm[:, 2]
    worst = int(np.argmax(np.abs(zs)))
    size_end = float(np.linalg.norm(static.hand_mm[0]))
    sizes = np.linalg.norm(moving.hand_mm, axis=1)
    largest = int(np.argmax(sizes))
    axes = f"(x{n}, y{n}, z{n})"
    law_note = "; the source paper's own law is in its Fig. 6, missing from the text" * paper
    t = np.arange(len(q)) * dt
    typer.echo(f"{arm.name}: flexible links {', '.join(str(i) for i in sorted(arm.sections))}")
    for i, s in sorted(arm.sections.items()):
        share = static.links[i]
        typer.echo(
            f"  link {i}: D {s.outer_mm:g} / d {s.inner_mm:g} mm, E {s.e_mpa:g} MPa; "
            f"tip moves {np.linalg.norm(share['tip_mm'][0]):.4f} mm; "
            f"share at the hand (x{n}, y{n}, z{n}) "
            + ", ".join(f"{v:+.4f}" for v in share["hand_mm"][0])
            + " mm"
        )
    typer.echo(
        f"end pose, static: hand deflection (x{n}, y{n}, z{n}) "
        + ", ".join(f"{v:+.4f}" for v in static.hand_mm[0])
        + " mm; rotation "
        + ", ".join(f"{v * 1e3:+.4f}" for v in static.hand_rot_rad[0])
        + " mrad"
    )
    typer.echo(
        f"along the motion ({duration:g} s, trapezoidal velocity law, {100 * ramp:g} % ramps"
        f"{law_note}): largest deflection {sizes[largest]:.4f} mm at t = {t[largest]:.3f} s, "
        f"{sizes[-1]:.4f} mm at the end (largest |dz{n}| {abs(zs[worst]):.4f} mm)"
    )
    typer.echo(
        f"hand deflection at the end pose: {size_end:.3f} mm, direction "
        f"{_direction(static.hand_mm[0], size_end)} in {axes}; z{n} component {dz_end:+.3f} mm"
    )
    document = {
        "model": model,
        "arm": arm.name,
        f"hand_dz{n}_mm": dz_end,
        "hand_deflection_mm": size_end,
        "end_pose": q[-1].tolist(),
        "static": {
            "hand_mm": static.hand_mm[0].tolist(),
            "hand_rot_rad": static.hand_rot_rad[0].tolist(),
            "links": {
                str(i): {k: v[0].tolist() for k, v in share.items()}
                for i, share in static.links.items()
            },
        },
        "trajectory": {
            "velocity_law": f"trapezoidal, ramp {ramp:g}",
            "t_s": t.tolist(),
            "hand_mm": moving.hand_mm.tolist(),
            "hand_rot_rad": moving.hand_rot_rad.tolist(),
            f"max_abs_dz{n}_mm": float(abs(zs[worst])),
            "max_deflection_mm": float(sizes[largest]),
        },
    }
    figure = None
    if plot is not None:
        from calibrator.analysis import deflection_plot

        figure = deflection_plot.workspace_map(
            arm, q[-1], map_joints, map_ranges, payload_kg=payload_kg
        )
    with outputs.Outputs(inputs=[sections]) as batch:
        if figure is not None:
            batch.bytes(plot, figure)
        if json_out is not None:
            batch.text(json_out, json.dumps(document, indent=2) + "\n")
    for path in (plot, json_out):
        if path is not None:
            typer.echo(f"wrote {path}")


def _is_path(name: str) -> bool:
    """A mass model named by its file (YAML), not by a named arm."""
    return name.lower().endswith((".yaml", ".yml")) or "/" in name or "\\" in name
