"""``calibrator identify``: MDH parameters from a session, written to calibration.json."""

from dataclasses import replace
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.errors import CalibrationError
from calibrator.identify.calibrate import JointOptions, calibrate
from calibrator.inputs.rules import Rule
from calibrator.recorded_options import RULES

#: --target-mm: below 0.1 um (no tracker's noise) the pose count overflows.
_TARGET = Rule("target_mm", float, 1e-4, 1e4, unit="mm", meaning="held-out error to reach")


class Method(StrEnum):
    hybrid = "hybrid"
    pso = "pso"
    lm = "lm"


class Loss(StrEnum):
    lsq = "lsq"
    huber = "huber"
    trimmed = "trimmed"
    minimax = "minimax"


@app.command()
@opts.urdf_links
def identify(
    ctx: typer.Context,
    session_paths: list[Path] = typer.Argument(
        ...,
        metavar="SESSION",
        help="Session file(s) (Parquet); several: one arm, e.g. at several payloads.",
    ),
    output: Path = opts.output(Path("calibration.json"), "Calibration file to write (JSON)."),
    force: bool = opts.force(),
    model: str = opts.model(None, "Named model instead of the session's."),
    method: Method = typer.Option(
        Method.hybrid,
        help="hybrid: swarm, then least squares; pso: swarm only; lm: least squares only.",
    ),
    loss: Loss = typer.Option(
        Loss.lsq,
        help="lsq: least squares; huber/trimmed: robust to outlier poses; "
        "minimax: smallest worst-pose error.",
    ),
    particles: int = typer.Option(
        20,
        callback=checks.rule(RULES["particles"]),
        help=f"Swarm size ({RULES['particles'].bounds}).",
    ),
    generations: int = typer.Option(
        2000,
        callback=checks.rule(RULES["generations"]),
        help=f"Swarm generations ({RULES['generations'].bounds}).",
    ),
    orientation_weight: float = typer.Option(
        None,
        "--orientation-weight",
        callback=checks.rule(RULES["k"]),
        help=f"Weight k of orientation errors ({RULES['k'].bounds}) [default: 1e4].",
    ),
    k: float = typer.Option(
        None, "--k", hidden=True, callback=checks.rule(RULES["k"]), help="Old name."
    ),
    validation_fraction: float = typer.Option(
        0.2,
        callback=checks.rule(RULES["validation_fraction"]),
        help=f"Share of poses held out for checking, in {RULES['validation_fraction'].bounds} "
        "(0 = fit all).",
    ),
    seed: int = typer.Option(
        0,
        callback=checks.rule(RULES["seed"]),
        help="Random seed of the hold-out split and the swarm.",
    ),
    noise_mm: float = typer.Option(
        0.05,
        callback=checks.rule(RULES["noise_mm"]),
        help="Measurement noise (mm per axis) assumed when deciding what the poses identify "
        f"({RULES['noise_mm'].bounds}).",
    ),
    tool_known: bool = typer.Option(
        None,
        "--tool-known/--tool-free",
        help="Fix or identify the tool frame (point; rotation with 6-DoF data) [default: session].",
    ),
    nominal_file: Path = typer.Option(
        None,
        "--nominal",
        help="Start from a factory calibration: UR DH deltas or a ROS kinematics YAML.",
    ),
    report_dir: Path = typer.Option(
        None, "--report", metavar="DIR", help="Also write the calibration report into DIR."
    ),
    like: Path = typer.Option(
        None,
        "--like",
        metavar="CALIBRATION",
        help="Re-run with the options recorded in this calibration file "
        "(options given here override them).",
    ),
    joint_terms_text: str = typer.Option(
        None,
        "--joint-terms",
        callback=checks.rule(RULES["joint_term_groups"]),
        help="Also fit joint terms: any of scale,harmonic,compliance; each kept only if "
        "it lowers the cross-validated error.",
    ),
    mass_model: str = typer.Option(
        None,
        callback=checks.rule(RULES["mass_model"]),
        help="Mass model for compliance: a named arm or a YAML [default: the model's].",
    ),
    payload_kg: float = typer.Option(
        None,
        callback=checks.rule(RULES["payload_kg"]),
        help=f"Payload ({RULES['payload_kg'].bounds}) of sessions that do not record one "
        "[default: 0].",
    ),
    payload_com_mm: str = typer.Option(
        "0,0,0",
        callback=checks.rule(RULES["payload_com_mm"]),
        help="Payload centre of mass in the flange frame, x,y,z "
        f"({RULES['payload_com_mm'].bounds}).",
    ),
    target_mm: float = typer.Option(
        None,
        callback=checks.rule(_TARGET),
        help="Print how many more poses would bring the parameter part of the held-out "
        "error below this (mm, 0.0001..10000).",
    ),
    quiet: bool = opts.quiet(),
    history: str = typer.Option(
        None,
        "--history",
        metavar="FILE|URL",
        help="Also record it in this history (docs/history.md).",
    ),
) -> None:
    """Identify MDH parameters from a session and write calibration.json."""

    from calibrator import outputs
    from calibrator.cli import progress
    from calibrator.identify import accuracy, pipeline, uncertainty

    if k is not None and orientation_weight is not None:
        raise CalibrationError("give --orientation-weight only (--k is its old name)")
    weight = orientation_weight if orientation_weight is not None else k
    options = pipeline.Options(
        method=method.value,
        particles=particles,
        generations=generations,
        k=weight,
        validation_fraction=validation_fraction,
        seed=seed,
        tool_known=tool_known,
        loss=loss.value,
        noise_mm=noise_mm,
    )
    session_path = session_paths[0]
    joint = JointOptions(joint_terms_text, mass_model, payload_kg, payload_com_mm)
    if like is not None:
        options, model, nominal_file, joint = _recorded(
            ctx, like, session_path, options, model, nominal_file, joint
        )
    inputs = [*session_paths, nominal_file, like]
    outputs.check(output, inputs=inputs, force=force)
    if report_dir is not None:
        from calibrator.report import FILES as REPORT_FILES

        outputs.check_folder(
            report_dir, inputs=inputs, files=REPORT_FILES, force=force, option="--report"
        )
        if report_dir.resolve() == output.resolve():
            raise CalibrationError(f"--report {report_dir} is the output file itself")
    if history is not None:  # a history it could not record into is refused before the work
        from calibrator.cli.history import refuse_unusable

        refuse_unusable(history)
    reporter = progress.Reporter.for_cli(quiet)
    if options.method == Method.lm.value:
        done = calibrate(
            session_paths, options, model=model, nominal_file=nominal_file, joint=joint
        )
    else:
        with reporter.task("swarm", options.generations, "generations") as task:
            done = calibrate(
                session_paths, options, model=model, nominal_file=nominal_file, joint=joint,
                on_generation=lambda g, best: task.update(g, best=best),
            )  # fmt: skip
    for note in done.notes:
        typer.echo(note, err=note.startswith("warning: "))
    cal, result, found, loaded = done.calibration, done.result, done.joint, done.session
    with outputs.Outputs(inputs=inputs) as batch:
        cal.save(output, batch=batch)
        if report_dir is not None:
            from calibrator.report import write as write_report

            write_report(report_dir, cal, loaded, batch, output, session_path, force=True)
    typer.echo(
        f"{len(result.fit_index)} fitted and {len(result.validation_index)} held-out poses, "
        f"{result.space.size} free parameters, method {options.method}, loss {options.loss}"
    )
    for item in result.dropped:
        typer.echo(f"  not identified: {item['name']:8s} {item['reason']}")
    for text in result.warnings:
        typer.echo(f"warning: {text}")
    if result.outliers and options.loss in ("huber", "trimmed"):
        typer.echo(f"outlier poses set aside: {', '.join(map(str, result.outliers))}")
    typer.echo(accuracy.format_table(result.stats))
    for line in uncertainty.summary_lines(result.uncertainty):
        typer.echo(line)
    typer.echo(uncertainty.noise_floor_line(result.uncertainty))
    if found is not None:
        from calibrator.identify import joint_fit

        for line in joint_fit.summary_lines(found):
            typer.echo(line)
    if target_mm is not None:
        typer.echo(_target_line(result, target_mm))
    also = f" and the report in {report_dir}" if report_dir is not None else ""
    typer.echo(f"identified in {done.took_s:.2f} s; wrote {output}{also}")
    if history is not None:
        from calibrator.cli.history import record

        record(history, "calibration", output)


def _recorded(ctx, like, session_path, options, model, nominal_file, joint):
    """Options, model, nominal file and joint-term options of ``--like``.

    Recorded ones are taken unless given here; each is checked by the rule
    its option has on the command line (:mod:`calibrator.recorded_options`).

    Raises
    ------
    CalibrationError
        A calibration that records no options, a recorded option its rule
        refuses, or a recorded nominal file that is gone or changed.
    """
    from calibrator import calibration

    cal = calibration.load(like)
    recorded = cal.provenance.options()
    if not recorded:
        raise CalibrationError(
            f"--like {like}: the file records no options (written before they were recorded)"
        )

    def given(flag):
        # The parameter that has this flag (--k is the old --orientation-weight).
        names = [p.name for p in ctx.command.params if flag in getattr(p, "opts", ())]
        if flag == "--orientation-weight":
            names.append("k")
        for name in names:
            # By name: typer may carry its own copy of click's ParameterSource.
            source = ctx.get_parameter_source(name)
            if source is not None and source.name not in ("DEFAULT", "DEFAULT_MAP"):
                return True
        return False

    # What the command line does not give is taken from the file, if its rule allows it.
    taken = cal.provenance.checked_options(
        f"--like {like}", [k for k, r in RULES.items() if r.flag is None or not given(r.flag)]
    )
    options = replace(
        options, **{k: v for k, v in taken.items() if k in calibration.Provenance.OPTION_KEYS}
    )
    for key in calibration.Provenance.JOINT_OPTION_KEYS:
        if key not in taken:
            continue
        value = taken[key]
        if key == "payload_com_mm":
            value = ",".join(repr(float(v)) for v in value)
        elif key == "joint_term_groups":
            value = value or None  # "" recorded: no joint terms
        joint = replace(joint, **{key: value})
    missing = [k for k in calibration.Provenance.OPTION_KEYS if k not in recorded]
    if missing:
        typer.echo(
            f"note: {like} does not record {', '.join(missing)}: "
            "those take the values given here (or their defaults)",
            err=True,
        )
    digest = calibration.digest(session_path)
    if cal.provenance.session_sha256 not in (None, digest):
        typer.echo(
            f"warning: {session_path} is not the session {like} was identified from "
            "(its SHA-256 differs); the options are re-used all the same",
            err=True,
        )
    if model is None and cal.provenance.nominal_source == "model":
        model = cal.model  # it was given with --model; else the session's own table
    recorded_nominal = cal.provenance.nominal_file
    if nominal_file is None and recorded_nominal is not None:
        nominal_file = Path(recorded_nominal)
        if not nominal_file.is_file():
            raise CalibrationError(
                f"--like {like}: its nominal file {nominal_file} is not there; "
                "give it with --nominal"
            )
        if calibration.digest(nominal_file) != cal.provenance.nominal_sha256:
            raise CalibrationError(
                f"--like {like}: its nominal file {nominal_file} has changed since "
                "(SHA-256 differs); give the one it used with --nominal"
            )
    return options, model, nominal_file, joint


def _target_line(result, target_mm):
    """``--target-mm``: more poses of the same kind for a parameter part below it."""
    from calibrator.identify import uncertainty

    pred = result.uncertainty.get("predicted_validation_mm")
    if not pred:
        return "--target-mm: no held-out poses to predict at (use --validation-fraction > 0)"
    n_fit = len(result.fit_index)
    more = uncertainty.poses_for_target(pred["model_rms_mean"], n_fit, target_mm)
    if more == 0:
        return f"parameter part {pred['model_rms_mean']:.4f} mm is already below {target_mm:g} mm"
    floor = uncertainty.noise_floor(result.uncertainty["residual_sigma"]["position_mm"])
    return (
        f"about {more} more poses like these ({n_fit + more} in all) bring the parameter part "
        f"from {pred['model_rms_mean']:.4f} to {target_mm:g} mm RMS; the mean held-out error "
        f"then approaches the noise floor {floor:.4f} mm"
    )
