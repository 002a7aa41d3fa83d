"""``calibrator identify``: MDH parameters from a session, written to calibration.json.

The options, their defaults and their rules are declared once, in
:mod:`calibrator.recorded_options` (:class:`~calibrator.recorded_options.Options`,
:class:`~calibrator.recorded_options.JointTermOptions`); this command reads
its defaults from them, hands what was typed to
:func:`calibrator.identify.calibrate.recall` for ``--like``, and prints.
"""

import functools
import inspect
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import typer
from typer._click import exceptions as _click_errors

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import app
from calibrator.errors import CalibrationError
from calibrator.inputs.rules import Rule
from calibrator.recorded_options import (
    DEFAULT_K,
    LOSSES,
    METHODS,
    RULES,
    JointTermOptions,
    Options,
)

#: --target-mm: below 0.1 um (no tracker's noise) the pose count overflows.
_TARGET = Rule("target_mm", float, 1e-4, 1e4, unit="mm", meaning="held-out error to reach")
#: The command's defaults: those of the options.
_DEFAULT, _JOINT = Options(), JointTermOptions()
#: The orientation weight taken when none is given, as help shows it ("1e4").
_DEFAULT_K = f"{DEFAULT_K:.0e}".replace("e+0", "e")
#: Option key of each parameter of the command that sets one: its own name, but
#: for these (``--k`` is the old name of ``--orientation-weight``).
_KEYS = {
    **{key: key for key in RULES},
    "orientation_weight": "k",
    "joint_terms_text": "joint_term_groups",
}


#: The choices of --method and --loss, from their rules.
Method = StrEnum("Method", [(m, m) for m in METHODS])  # type: ignore[misc]
Loss = StrEnum("Loss", [(name, name) for name in LOSSES])  # type: ignore[misc]
_METHOD, _LOSS = Method(_DEFAULT.method), Loss(_DEFAULT.loss)


def _option(key: str, help: str, *flags: str, **kw: Any) -> Any:
    """The typer option of ``key``: its default and its rule's check from the declaration."""
    default = getattr(_DEFAULT if key in Options.rules() else _JOINT, key)
    return typer.Option(default, *flags, callback=checks.rule(RULES[key]), help=help, **kw)


#: The parameters of the options :class:`Options` and :class:`JointTermOptions`
#: declare, with their typer options (the field's default, the rule's check),
#: each group after the parameter it is keyed by, in the order help lists them.
#: The command reads them through :func:`_given`, not as arguments.
_RECORDED_PARAMS: dict[str, dict[str, Any]] = {
    "model": {
        "method": typer.Option(
            _METHOD,
            help="hybrid: swarm, then least squares; pso: swarm only; lm: least squares only.",
        ),
        "loss": typer.Option(
            _LOSS,
            help="lsq: least squares; huber/trimmed: robust to outlier poses; "
            "minimax: smallest worst-pose error.",
        ),
        "particles": _option("particles", f"Swarm size ({RULES['particles'].bounds})."),
        "generations": _option(
            "generations", f"Swarm generations ({RULES['generations'].bounds})."
        ),
        "orientation_weight": _option(
            "k",
            f"Weight k of orientation errors ({RULES['k'].bounds}) [default: {_DEFAULT_K}].",
            "--orientation-weight",
        ),
        "k": _option("k", "Old name.", "--k", hidden=True),
        "validation_fraction": _option(
            "validation_fraction",
            f"Share of poses held out for checking, in {RULES['validation_fraction'].bounds} "
            "(0 = fit all).",
        ),
        "seed": _option("seed", "Random seed of the hold-out split and the swarm."),
        "noise_mm": _option(
            "noise_mm",
            "Measurement noise (mm per axis) assumed when deciding what the poses identify "
            f"({RULES['noise_mm'].bounds}).",
        ),
        "tool_known": typer.Option(
            _DEFAULT.tool_known,
            "--tool-known/--tool-free",
            help="Fix or identify the tool frame (point; rotation with 6-DoF data) "
            "[default: session].",
        ),
    },
    "like": {
        "joint_terms_text": typer.Option(
            None,  # not given: the default, no joint terms
            "--joint-terms",
            callback=checks.rule(RULES["joint_term_groups"]),
            help="Also fit joint terms: any of scale,harmonic,compliance; each kept only if "
            "it lowers the cross-validated error.",
        ),
        "mass_model": _option(
            "mass_model", "Mass model for compliance: a named arm or a YAML [default: the model's]."
        ),
        "payload_kg": _option(
            "payload_kg",
            f"Payload ({RULES['payload_kg'].bounds}) of sessions that do not record one "
            "[default: 0].",
        ),
        "payload_com_mm": typer.Option(
            ",".join(f"{v:g}" for v in _JOINT.payload_com_mm),
            callback=checks.rule(RULES["payload_com_mm"]),
            help="Payload centre of mass in the flange frame, x,y,z "
            f"({RULES['payload_com_mm'].bounds}).",
        ),
    },
}


def _kind(name: str) -> Any:
    """The type typer converts parameter ``name`` to: its rule's (``X,Y,Z`` as text)."""
    kind = {"method": Method, "loss": Loss}.get(name) or RULES[_KEYS[name]].kind
    return str if kind is tuple else kind


def _with_recorded_options(command: Callable[..., None]) -> Callable[..., None]:
    """Give ``command`` the parameters of :data:`_RECORDED_PARAMS`; it receives the others.

    Use it below :func:`calibrator.cli._options.urdf_links`.
    """
    signature = inspect.signature(command)
    params: list[inspect.Parameter] = []
    for p in signature.parameters.values():
        params.append(p)
        for name, option in _RECORDED_PARAMS.get(p.name, {}).items():
            params.append(inspect.Parameter(name, p.kind, default=option, annotation=_kind(name)))
    added = {name for group in _RECORDED_PARAMS.values() for name in group}

    @functools.wraps(command)
    def declared(*args: Any, **given: Any) -> None:
        command(*args, **{k: v for k, v in given.items() if k not in added})

    declared.__signature__ = inspect.Signature(params, return_annotation=None)  # type: ignore[attr-defined]
    declared.__annotations__ = {p.name: p.annotation for p in params}
    return declared


@app.command()
@opts.urdf_links
@_with_recorded_options
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
    from calibrator.identify.calibrate import calibrate

    session_path = session_paths[0]
    asked = _asked(ctx, model, nominal_file, like, session_path)
    options, inputs = asked.options, [*session_paths, asked.nominal_file, like]
    outputs.check(output, inputs=inputs, force=force)
    if report_dir is not None:
        from calibrator.report import FILES as REPORT_FILES

        outputs.check_folder(
            report_dir, inputs=inputs, files=REPORT_FILES, force=force, option="--report"
        )
        if report_dir.resolve() == output.resolve():
            raise CalibrationError(f"--report {report_dir} is the output file itself")
    if history is not None:  # a history it could not record into is refused before the work
        from calibrator.cli._history_record import refuse_unusable

        refuse_unusable(history)
    reporter = progress.Reporter.for_cli(quiet)

    def identified(on_generation=None):
        return calibrate(
            session_paths, options, model=asked.model, nominal_file=asked.nominal_file,
            joint=asked.joint, on_generation=on_generation,
        )  # fmt: skip

    if options.method == "lm":  # no swarm to show
        done = identified()
    else:
        with reporter.task("swarm", options.generations, "generations") as task:
            done = identified(lambda g, best: task.update(g, best=best))
    for note in done.notes:
        typer.echo(note, err=note.startswith("warning: "))
    with outputs.Outputs(inputs=inputs) as batch:
        done.calibration.save(output, batch=batch)
        if report_dir is not None:
            from calibrator.report import write as write_report

            write_report(
                report_dir, done.calibration, done.session, batch, output, session_path,
                force=True,
            )  # fmt: skip
    _summary(done, options, target_mm)
    also = f" and the report in {report_dir}" if report_dir is not None else ""
    typer.echo(f"identified in {done.took_s:.2f} s; wrote {output}{also}")
    if history is not None:
        from calibrator.cli._history_record import record

        record(history, "calibration", output)


@dataclass(frozen=True)
class Asked:
    """What a command line asks identify to do, bar where to write.

    Attributes
    ----------
    options : calibrator.recorded_options.Options
    joint : calibrator.recorded_options.JointTermOptions
    model : str or None
    nominal_file : Path or None
    """

    options: Options
    joint: JointTermOptions
    model: str | None = None
    nominal_file: Path | None = None


def _asked(ctx, model, nominal_file, like, session_path) -> Asked:
    """The options typed (``ctx``), completed by the ones ``--like`` records.

    Raises
    ------
    CalibrationError
        Both ``--k`` and ``--orientation-weight``, or what
        :func:`calibrator.identify.calibrate.recall` refuses.
    """
    given = _given(ctx)
    if like is None:
        return Asked(
            Options(**_only(given, Options)),
            JointTermOptions(**_only(given, JointTermOptions)),
            model,
            nominal_file,
        )
    from calibrator.identify.calibrate import recall

    found = recall(like, session_path, given, model=model, nominal_file=nominal_file)
    for note in found.notes:
        typer.echo(note, err=True)
    return Asked(found.options, found.joint, found.model, found.nominal_file)


def _only(given, kind):
    return {k: v for k, v in given.items() if k in kind.rules()}


def _given(ctx: typer.Context) -> dict[str, Any]:
    """The options typed on the command line, ``{key: value}`` as the option records hold them."""
    from calibrator.model import joint_terms

    given: dict[str, Any] = {}
    for name, key in _KEYS.items():
        if name not in ctx.params:
            continue
        value = ctx.params[name]
        # By name: typer may carry its own copy of click's ParameterSource.
        source = ctx.get_parameter_source(name)
        if value is None or source is None or source.name in ("DEFAULT", "DEFAULT_MAP"):
            continue
        if key in given:
            raise CalibrationError("give --orientation-weight only (--k is its old name)")
        if key == "joint_term_groups":
            value = joint_terms.parse_groups(value)
        elif key in ("method", "loss"):
            value = str(getattr(value, "value", value))
        else:
            value = RULES[key].check(value, RULES[key].flag or key)
        given[key] = value
    return given


def asked_by(args: Sequence[str]) -> Asked:
    """What identify's options ``args`` ask (``["--method", "lm"]``), as the command reads them.

    For ``history reidentify``, which hands them to
    :func:`calibrator.identify.calibrate.run` for every session; the options
    that write or re-use files (``-o``, ``--report``, ``--history``,
    ``--like``) are its own.

    Raises
    ------
    CalibrationError
        An option the command would refuse, in its one line.
    """
    import typer.main

    single = typer.Typer()
    single.command()(identify)
    command = typer.main.get_command(single)
    try:
        checks.strict_numbers(single, list(args))
        ctx = command.make_context("identify", ["SESSION", *args])
    except _click_errors.ClickException as exc:
        raise CalibrationError(
            checks.one_line(exc)
            if isinstance(exc, _click_errors.UsageError)
            else exc.format_message()
        ) from None
    model = opts.chain_name(ctx.params["model"], ctx.params["base_link"], ctx.params["tip_link"])
    nominal = ctx.params.get("nominal_file")
    return _asked(ctx, model, None if nominal is None else Path(nominal), None, None)


def _summary(done, options, target_mm):
    """What identify prints about its result (stdout)."""
    result, found = done.result, done.joint
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
    from calibrator.identify import accuracy, uncertainty

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
