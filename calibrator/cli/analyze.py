"""``calibrator analyze``: accuracy studies (misalignment Monte Carlo, tolerance budget)."""

import json
import time
from enum import StrEnum
from pathlib import Path

import typer

from calibrator.cli import _checks as checks
from calibrator.cli import _options as opts
from calibrator.cli._app import analyze_app, app
from calibrator.errors import CalibrationError

app.add_typer(analyze_app, name="analyze")


class Distribution(StrEnum):
    uniform = "uniform"
    normal = "normal"


#: Physical ranges of the study inputs: beyond them the Monte Carlo and the
#: linear budget overflow into nan and inf (1e308 sweeps printed nan with exit 0).
#: (low, high, unit); a bearing's radial clearance is microns to a millimetre,
#: the distance between its end faces millimetres to a metre.
RANGES = {
    "length": (-1e5, 1e5, "mm"),  # as any MDH length (calibrator.model.consistency.MAX_MDH)
    "r0": (0.0, 10.0, "mm"),
    "h": (1.0, 10_000.0, "mm"),
    "pose": (-360.0, 360.0, "deg"),
    "length_tol": (0.0, 100.0, "mm"),
    "angle_tol": (0.0, 10.0, "deg"),
}


def _floats(text, what, n=None, bounds=None):
    """Comma-separated numbers (strict grammar); one value is repeated to ``n`` when given.

    ``bounds`` is a key of :data:`RANGES` every value must lie in.
    """
    from calibrator.inputs import grammar
    from calibrator.inputs.errors import StrictError

    try:
        # Every item, an empty one too: "0.05," is a value missing, not one value.
        values = [grammar.parse_number(v, what) for v in str(text).split(",")]
    except StrictError as exc:
        reason = str(exc).removeprefix(f"{what}: ")
        raise CalibrationError(
            f"{what} must be comma-separated numbers, got {text!r} ({reason})"
        ) from None
    if bounds is not None:
        _in_range(values, what, bounds)
    if n is not None:
        if len(values) == 1:
            values = values * n
        if len(values) != n:
            raise CalibrationError(f"{what} needs 1 or {n} values, got {len(values)}")
    return values


def _in_range(values, what, key):
    """Refuse a value outside ``RANGES[key]``, naming it with its unit."""
    low, high, unit = RANGES[key]
    bad = [v for v in values if not low <= v <= high]
    if bad:
        raise CalibrationError(f"{what}: {bad[0]:g} {unit} is outside [{low:g}, {high:g}] {unit}")


def _finite_result(value, what):
    """Fail loudly rather than print nan or inf: every number of a result must be finite."""
    import numpy as np

    def numbers(v):
        if isinstance(v, dict):
            for x in v.values():
                yield from numbers(x)
        elif isinstance(v, list | tuple | np.ndarray):
            for x in v:
                yield from numbers(x)
        elif isinstance(v, int | float | np.number) and not isinstance(v, bool):
            yield float(v)

    if not all(np.isfinite(x) for x in numbers(value)):
        raise CalibrationError(
            f"the {what} gave non-finite numbers: the inputs are beyond what it can compute"
        )


def _assignment(text, what, bounds=None):
    """``NAME=VALUE[,VALUE...]`` -> (name, [values])."""
    name, sep, values = str(text).partition("=")
    if not sep or not name.strip():
        raise CalibrationError(f"{what} must look like NAME=VALUE, got {text!r}")
    return name.strip(), _floats(values, f"{what} {name.strip()}", bounds=bounds)


_HEADER = f"{'case':24s} {'PDF peak':>9s} {'CDF 50%':>9s} {'CDF 90%':>9s} {'CDF 98%':>9s} "
_HEADER += f"{'max':>9s} {'|mean|':>9s}"


def _row(label, stats):
    p = stats["position"]
    centre = sum(v * v for v in p["mean_vector"]) ** 0.5
    values = [p[k] for k in ("pdf_peak", "cdf50", "cdf90", "cdf98", "max")] + [centre]
    return f"{label:24s} " + " ".join(f"{v:9.4f}" for v in values)


@analyze_app.command("misalignment")
@opts.urdf_links
def misalignment(
    model: str = opts.model(
        "paper",
        "'paper' (the misalignment paper's arm, Craig DH) or a named model (ur5e, ur10e, ...).",
    ),
    pose: str = typer.Option(
        None, help="Six joint angles, deg [default: the paper's pose; zeros for a named model]."
    ),
    r0: str = typer.Option("0.05", "--r0", help="Radial clearance R0 (mm), one value or six."),
    h: str = typer.Option(
        None, "--h", help="End-face distance h (mm), one value or six [default: 267, see docs]."
    ),
    trials: int = typer.Option(20000, callback=checks.count("trials"), help="Monte Carlo trials."),
    seed: int = opts.seed(0, "Seed; results depend only on seed and trials."),
    sweep_r0: str = typer.Option(None, help="Also run with every joint's R0 at each value (mm)."),
    sweep_length: str = typer.Option(
        None, help="Also run with one link length at each value, e.g. d3=800,1000,1200 (mm)."
    ),
    plots: Path = typer.Option(
        None, metavar="DIR", help="Folder to write the PNG figures into (created if missing)."
    ),
    json_out: Path = typer.Option(None, "--json", help="Write all statistics to this JSON file."),
    force: bool = opts.force(),
    chunk: int = typer.Option(
        None,
        callback=checks.count("trials"),
        help="Trials per chunk (rounded to blocks of 10,000).",
    ),
    workers: int = typer.Option(
        None,
        callback=checks.cores(),
        help="Run on a Dask LocalCluster of N worker processes (at most this machine's cores).",
    ),
    scheduler: str = typer.Option(None, help="Run on an existing Dask cluster at this address."),
    quiet: bool = opts.quiet(),
) -> None:
    """Joint-axis misalignment Monte Carlo: hand error statistics and figures."""
    import numpy as np

    from calibrator import outputs
    from calibrator.analysis import arm, engine
    from calibrator.analysis import misalignment as mc
    from calibrator.cli import progress
    from calibrator.inputs import budgets

    if workers is not None and scheduler is not None:
        raise CalibrationError("give --workers or --scheduler, not both")
    if json_out is not None:
        outputs.check(json_out, force=force, option="--json")
    if plots is not None:
        outputs.check_folder(plots, files=MISALIGNMENT_FIGURES, force=force, option="--plots")
    pose_deg = None if pose is None else _floats(pose, "--pose", 6, "pose")
    r0_mm = np.array(_floats(r0, "--r0", 6, "r0"))
    h_mm = np.array(_floats(h, "--h", 6, "h") if h is not None else [mc.PAPER_H_MM] * 6)
    cases = [("base", {}, r0_mm)]
    if sweep_r0 is not None:
        sweep = _floats(sweep_r0, "--sweep-r0", bounds="r0")
        cases += [(f"R0={v:g}", {}, np.full(6, v)) for v in sweep]
    if sweep_length is not None:
        name, values = _assignment(sweep_length, "--sweep-length", "length")
        cases += [(f"{name}={v:g}", {name: v}, r0_mm) for v in values]
    budgets.check_budget("sweep values", len(cases) - 1, *checks.BUDGETS["sweep_values"])
    budgets.check_budget("--trials x cases", trials * len(cases), *checks.BUDGETS["sweep_work"])
    # Build every arm and study first: a bad option fails before any work.
    studies = [
        (label, mc.Study(arm.build(model, pose_deg, lengths), r, h_mm, trials, seed))
        for label, lengths, r in cases
    ]
    typer.echo(
        f"{studies[0][1].arm.name}: {trials} trials, seed {seed}, "
        f"R0 {', '.join(f'{v:g}' for v in r0_mm)} mm, h {', '.join(f'{v:g}' for v in h_mm)} mm"
    )
    typer.echo("|dP| (mm)")
    typer.echo(_HEADER)
    reporter = progress.Reporter.for_cli(quiet)
    results, started = [], time.perf_counter()
    for label, study in studies:
        with reporter.task(f"misalignment {label}", trials, "trials") as task:
            summary, grid = engine.run(
                study,
                chunk_trials=chunk,
                workers=workers,
                scheduler=scheduler,
                progress=lambda done, _total, task=task: task.update(done),
            )
        stats = mc.statistics(summary, grid)
        _finite_result(stats, f"misalignment study {label}")
        results.append((label, study, summary, grid, stats))
        typer.echo(_row(label, stats))
    base = results[0][4]
    typer.echo(
        "density centre (mean dP, base frame, mm): "
        + ", ".join(f"{v:+.4f}" for v in base["position"]["mean_vector"])
    )
    typer.echo("orientation error (deg)   mean       std   max |.|  axis-angle median / max")
    for axis, o in base["orientation_deg"].items():
        typer.echo(
            f"  about {axis}            {o['mean']:+.5f}  {o['std']:.5f}  {o['max_abs']:.5f}"
            f"  {o['axis_angle_median']:.5f} / {o['axis_angle_max']:.5f}"
        )
    outside = sum(base["outside"].values())
    if outside:
        typer.echo(f"note: {outside} values fell outside the figure ranges (statistics exact)")
    typer.echo(f"done in {time.perf_counter() - started:.2f} s")
    document = {
        "model": model,
        "trials": trials,
        "seed": seed,
        "h_mm": h_mm.tolist(),
        "cases": [
            {"case": label, "r0_mm": s.r0_mm.tolist(), **stats} for label, s, _, _, stats in results
        ],
    }
    with outputs.Outputs() as batch:
        if plots is not None:
            _misalignment_plots(batch, plots, results)
        if json_out is not None:
            batch.text(json_out, json.dumps(document, indent=2) + "\n")
    if json_out is not None:
        typer.echo(f"wrote {json_out}")


#: The figures every ``misalignment --plots`` run writes (sweeps add more).
MISALIGNMENT_FIGURES = ("cloud.png", "orientation.png", "pdf_cdf.png")


def _misalignment_plots(batch, folder, results):
    """Add every figure of the runs to an output batch."""
    from calibrator.analysis import plots

    folder = batch.folder(folder)
    _, _, summary, grid, _ = results[0]
    figures = {
        "cloud.png": plots.cloud(summary, grid, "hand error, ideal point at origin"),
        "orientation.png": plots.orientation(summary, grid),
    }
    r0_runs = [r for r in results if r[0].startswith("R0=")] or results[:1]
    figures["pdf_cdf.png"] = plots.pdf_cdf([(r[0], r[2], r[3]) for r in r0_runs])
    r0_sweep = [r for r in results[1:] if r[0].startswith("R0=")]
    length_sweep = [r for r in results[1:] if not r[0].startswith("R0=")]
    for name, runs in (("sweep_r0.png", r0_sweep), ("sweep_length.png", length_sweep)):
        if len(runs) > 1:
            xlabel = "R0 (mm)" if runs is r0_sweep else f"{runs[0][0].split('=')[0]} (mm)"
            xs = [float(r[0].split("=")[1]) for r in runs]
            figures[name] = plots.sweep(xlabel, xs, [r[4] for r in runs])
    for label, _, summary, grid, _ in length_sweep:
        figures[f"cloud_{label.replace('=', '-')}.png"] = plots.cloud(summary, grid, label)
    for name, png in figures.items():
        batch.bytes(folder / name, png)
    typer.echo(f"wrote {len(figures)} figures into {folder}: {', '.join(figures)}")


@analyze_app.command("tolerance")
@opts.urdf_links
def tolerance(
    model: str = opts.model(None, "Named model giving the nominal table."),
    calibration: Path = typer.Option(
        None,
        help="calibration.json: its identified table is the nominal, and each identified "
        "parameter's tolerance is 3 x its standard error (normal) unless set with --tol.",
    ),
    length_tol: float = typer.Option(
        0.05,
        callback=checks.finite(*RANGES["length_tol"][:2]),
        help="Tolerance of every a and d (+- mm).",
    ),
    angle_tol: float = typer.Option(
        0.01,
        callback=checks.finite(*RANGES["angle_tol"][:2]),
        help="Tolerance of every alpha, theta, beta (+- deg).",
    ),
    joint_tol: float = typer.Option(
        0.01,
        callback=checks.finite(*RANGES["angle_tol"][:2]),
        help="Tolerance of every joint coordinate (+- deg).",
    ),
    tol: list[str] = typer.Option(
        None, help="Override one tolerance, NAME=VALUE (mm or deg), e.g. a2=0.02. Repeatable."
    ),
    distribution: Distribution = typer.Option(
        Distribution.uniform, help="Inside the band: uniform, or normal with tolerance = 3 sigma."
    ),
    pose: str = typer.Option(None, help="One pose, six joint angles (deg) [default: random]."),
    poses: int = typer.Option(
        100, callback=checks.count("tolerance_poses"), help="Random poses within the joint limits."
    ),
    samples: int = typer.Option(
        2000, callback=checks.count("samples"), help="Deviation sets for the nonlinear check."
    ),
    seed: int = opts.seed(0, "Seed of the random poses and of the nonlinear draws."),
    top: int = typer.Option(
        10, callback=checks.at_least(0), help="Rows of the sensitivity ranking to print."
    ),
    json_out: Path = typer.Option(None, "--json", help="Write the budget to this JSON file."),
    force: bool = opts.force(),
) -> None:
    """Tolerance budget: worst-case and statistical hand error, and what to tighten first."""
    import numpy as np

    from calibrator import outputs, robots
    from calibrator.analysis import tolerance as tl
    from calibrator.inputs import budgets

    n_poses = 1 if pose is not None else poses
    budgets.check_budget(
        "--poses x --samples", n_poses * samples, *checks.BUDGETS["tolerance_work"]
    )

    if (model is None) == (calibration is None):
        raise CalibrationError("give exactly one of --model and --calibration")
    if json_out is not None:
        outputs.check(json_out, inputs=[calibration], force=force, option="--json")
    if calibration is not None:
        from calibrator import calibration as cal

        loaded = cal.load(calibration)
        nominal, source = loaded.mdh, f"{calibration} (identified table)"
        limits = robots.get(loaded.model).joint_limits_rad if loaded.model else None
    else:
        m = robots.get(model)
        nominal, source, limits = m.mdh, m.name, m.joint_limits_rad
    overrides = {}
    for item in tol or []:
        name, values = _assignment(item, "--tol")
        if len(values) != 1:
            raise CalibrationError(f"--tol {name} takes one value, got {len(values)}")
        _in_range(values, f"--tol {name}", "length_tol" if tl.is_length(name) else "angle_tol")
        overrides[name] = values[0] if tl.is_length(name) else np.radians(values[0])
    # Which entries an arm has is the design's: an identified table is parallel only nearly.
    design = loaded.nominal_mdh if calibration is not None else nominal
    meaningless = tl.without_meaning(design)
    for name in overrides:
        if name in meaningless:
            raise CalibrationError(
                f"--tol {name}: no physical quantity of this arm ({meaningless[name]})"
            )
    tols = tl.Tolerances.build(
        length_tol, np.radians(angle_tol), np.radians(joint_tol), overrides, distribution.value
    )
    from_errors = None
    if calibration is not None:
        try:
            tols, from_errors = tl.from_calibration(loaded, np.radians(joint_tol))
        except CalibrationError as exc:
            typer.echo(f"note: {exc}; using the uniform tolerances given")
        else:
            t = tols.t.copy()
            for name, value in overrides.items():
                t[tl.NAMES.index(name)] = value
            tols = tl.Tolerances(t, tols.distribution)
    if pose is not None:
        q = np.radians([_floats(pose, "--pose", 6, "pose")])
    else:
        lim = np.tile([-np.pi, np.pi], (6, 1)) if limits is None else limits
        lo, hi = np.maximum(lim[:, 0], -np.pi), np.minimum(lim[:, 1], np.pi)
        q = np.random.default_rng(seed).uniform(lo, hi, (poses, 6))
    result = tl.budget(nominal, q, tols, samples=samples, seed=seed, structure=design)
    _finite_result(result, "tolerance budget")
    nl = result["nonlinear"]
    typer.echo(f"nominal: {source}; {len(q)} poses; {tols.distribution} deviations")
    if from_errors is not None:
        typer.echo(
            f"tolerances of the {len(from_errors)} identified parameters: "
            f"{tl.SIGMAS:g} x their standard errors; the others held at nominal"
        )
    if meaningless:
        typer.echo("not toleranced (no physical quantity of this arm): " + ", ".join(meaningless))
    typer.echo(f"worst case |dP| (linear bound, worst pose)   {result['worst_case_mm']:9.4f} mm")
    typer.echo(
        f"worst case along one axis (worst pose)       {result['worst_case_axis_mm']:9.4f} mm"
    )
    typer.echo(f"statistical RMS |dP| (linear)                {result['rms_mm']:9.4f} mm")
    typer.echo(
        f"  from link parameters / from joints         {result['link_only_rms_mm']:9.4f}"
        f" / {result['joint_only_rms_mm']:.4f} mm"
    )
    typer.echo(
        f"statistical RMS orientation (linear)         {result['orientation_rms_deg']:9.5f} deg"
    )
    typer.echo(
        f"nonlinear model, {nl['samples']} draws: RMS {nl['rms_mm']:.4f}, 95 % {nl['p95_mm']:.4f},"
        f" max {nl['max_mm']:.4f} mm; linearisation error {100 * nl['linearisation_error']:.3f} %"
    )
    typer.echo("tighten first (share of position variance):")
    typer.echo(f"  {'param':8s} {'tolerance':>12s} {'share':>7s} {'RMS mm':>8s} {'worst mm':>9s}")
    for row in result["ranking"][:top]:
        band = row["tolerance"] if row["unit"] == "mm" else np.degrees(row["tolerance"])
        unit = "mm" if row["unit"] == "mm" else "deg"
        typer.echo(
            f"  {row['name']:8s} {band:8.4f} {unit:3s} {100 * row['share']:6.1f}% "
            f"{row['rms_mm']:8.4f} {row['worst_mm']:9.4f}"
        )
    if json_out is not None:
        text = json.dumps({"nominal": source, **result}, indent=2) + "\n"
        outputs.write_text(json_out, text, inputs=[calibration])
        typer.echo(f"wrote {json_out}")


# Registers ``analyze deflection`` on :data:`analyze_app` (its own module).
from calibrator.cli import analyze_deflection as _deflection  # noqa: E402,F401  isort: skip
