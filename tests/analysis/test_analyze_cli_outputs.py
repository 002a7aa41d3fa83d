"""``calibrator analyze`` in-process: the figures it writes show its statistics; refusals.

The figures are read back from the written files: a recorder stands in for
``plots._png`` and writes a token per figure, so each file name maps to the
matplotlib figure that went into it (rendering is checked in
``test_misalignment_plots.py``).
"""

import json

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator import robots
from calibrator.analysis import plots
from calibrator.analysis import tolerance as tl


@pytest.fixture
def figures(monkeypatch):
    """Figure by token: the bytes each plotting call returned instead of a PNG."""
    seen = {}

    def record(fig):
        token = f"figure {len(seen)}".encode()
        seen[token] = fig
        return token

    monkeypatch.setattr(plots, "_png", record)
    return seen


def written(folder, figures):
    """File name -> the figure written into it."""
    return {p.name: figures[p.read_bytes()] for p in sorted(folder.iterdir())}


def lines(ax):
    return {line.get_label(): line.get_xydata() for line in ax.lines}


def cases(doc):
    return {c["case"]: c for c in doc["cases"]}


def test_plots_show_each_case_and_the_sweeps(tmp_path, figures):
    out = cli(
        "analyze", "misalignment", "--trials", "300", "--sweep-r0", "0.025,0.05",
        "--sweep-length", "d3=800,1200", "--plots", "figs", "--json", "s.json", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    names = [
        "cloud.png", "cloud_d3-1200.png", "cloud_d3-800.png", "orientation.png",
        "pdf_cdf.png", "sweep_length.png", "sweep_r0.png",
    ]  # fmt: skip
    figs = written(tmp_path / "figs", figures)
    assert sorted(figs) == names
    assert "wrote 7 figures into figs: cloud.png, orientation.png, pdf_cdf.png" in out.stdout
    doc = cases(json.loads((tmp_path / "s.json").read_text()))
    # Each cloud is its own case: the density centre is the case's mean error.
    for name, case, title in (
        ("cloud.png", "base", "hand error, ideal point at origin"),
        ("cloud_d3-800.png", "d3=800", "d3=800"),
        ("cloud_d3-1200.png", "d3=1200", "d3=1200"),
    ):
        fig = figs[name]
        assert fig._suptitle.get_text() == title
        mean = doc[case]["position"]["mean_vector"]
        for ax, (a, b) in zip(fig.axes, ((0, 1), (0, 2), (1, 2)), strict=True):
            np.testing.assert_allclose(lines(ax)["density centre"], [[mean[a], mean[b]]])
    # The R0 sweep replaces the base case in the PDF/CDF figure.
    assert list(lines(figs["pdf_cdf.png"].axes[0])) == ["R0=0.025", "R0=0.05"]
    for name, xlabel, swept, xs in (
        ("sweep_r0.png", "R0 (mm)", ["R0=0.025", "R0=0.05"], [0.025, 0.05]),
        ("sweep_length.png", "d3 (mm)", ["d3=800", "d3=1200"], [800.0, 1200.0]),
    ):
        (ax,) = figs[name].axes
        assert ax.get_xlabel() == xlabel
        for key, label in (("pdf_peak", "PDF peak"), ("cdf50", "CDF 50 %"), ("cdf98", "CDF 98 %")):
            expected = [[x, doc[c]["position"][key]] for x, c in zip(xs, swept, strict=True)]
            np.testing.assert_allclose(lines(ax)[label], expected)
    # The orientation figure is the base case's: its densities hold all its trials.
    for ax in figs["orientation.png"].axes:
        for xy in lines(ax).values():
            assert np.sum(xy[:, 1]) * (xy[1, 0] - xy[0, 0]) == pytest.approx(1.0)


@pytest.mark.parametrize(
    "extra, names, pdf_runs",
    [
        ([], ["cloud.png", "orientation.png", "pdf_cdf.png"], ["base"]),
        # A length sweep alone: the PDF/CDF figure shows the base case.
        (
            ["--sweep-length", "d3=900,1000"],
            [
                "cloud.png",
                "cloud_d3-1000.png",
                "cloud_d3-900.png",
                "orientation.png",
                "pdf_cdf.png",
                "sweep_length.png",
            ],
            ["base"],
        ),
        # One value per sweep: nothing to draw a curve through, but its cloud still comes.
        (
            ["--sweep-r0", "0.03", "--sweep-length", "a2=150"],
            ["cloud.png", "cloud_a2-150.png", "orientation.png", "pdf_cdf.png"],
            ["R0=0.03"],
        ),
    ],
)
def test_plots_without_a_curve_to_sweep(extra, names, pdf_runs, tmp_path, figures):
    out = cli(
        "analyze", "misalignment", "--trials", "200", "--plots", "figs", "-q", *extra, cwd=tmp_path
    )
    assert out.code == 0, out.stderr
    figs = written(tmp_path / "figs", figures)
    assert sorted(figs) == names
    assert list(lines(figs["pdf_cdf.png"].axes[0])) == pdf_runs
    assert f"wrote {len(names)} figures into figs" in out.stdout


def test_printed_rows_are_the_json_statistics(tmp_path):
    out = cli(
        "analyze", "misalignment", "--trials", "500", "--sweep-r0", "0.02", "--json", "s.json",
        "-q", cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    doc = cases(json.loads((tmp_path / "s.json").read_text()))
    rows = {line.split(" ")[0]: line for line in out.stdout.splitlines()}
    rows = {case: line for case, line in rows.items() if case in doc}
    assert list(rows) == ["base", "R0=0.02"]
    for case, line in rows.items():
        p = doc[case]["position"]
        assert line.startswith(f"{case:24s} ")
        values = [float(v) for v in line[25:].split(" ") if v]
        assert len(line) == 25 + 6 * 9 + 5  # six fixed-width columns, one space apart
        centre = np.linalg.norm(p["mean_vector"])
        expected = [p["pdf_peak"], p["cdf50"], p["cdf90"], p["cdf98"], p["max"], centre]
        np.testing.assert_allclose(values, expected, atol=5.1e-5)


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["--r0", "nan"],
            "--r0 must be comma-separated numbers, got 'nan' ('nan' is not a decimal number)",
        ),
        (
            ["--r0", "0.05,inf"],
            "--r0 must be comma-separated numbers, got '0.05,inf' ('inf' is not a decimal number)",
        ),
        (
            ["--r0", "-inf"],
            "--r0 must be comma-separated numbers, got '-inf' ('-inf' is not a decimal number)",
        ),
        (
            ["--sweep-r0", " , "],
            "--sweep-r0 must be comma-separated numbers, got ' , ' ('' is not a decimal number)",
        ),
        (["--pose", "1,2,3"], "--pose needs 1 or 6 values, got 3"),
        (["--sweep-length", "d3"], "--sweep-length must look like NAME=VALUE, got 'd3'"),
        (["--sweep-length", "=800"], "--sweep-length must look like NAME=VALUE, got '=800'"),
        (
            ["--sweep-length", "d3=800=900"],
            "--sweep-length d3 must be comma-separated numbers, got '800=900' "
            "('800=900' is not a decimal number)",
        ),
        (
            ["--sweep-length", "d3=nan"],
            "--sweep-length d3 must be comma-separated numbers, got 'nan' "
            "('nan' is not a decimal number)",
        ),
    ],
)
def test_misalignment_option_refusals(args, message, tmp_path):
    out = cli("analyze", "misalignment", "--trials", "10", *args, cwd=tmp_path)
    assert one_line_error(out) == f"calibrator: error: {message}"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "args, message",
    [
        (["--tol", "a2"], "--tol must look like NAME=VALUE, got 'a2'"),
        (
            ["--tol", "a2=x"],
            "--tol a2 must be comma-separated numbers, got 'x' ('x' is not a decimal number)",
        ),
        (["--tol", "a2=0.1,0.2"], "--tol a2 takes one value, got 2"),
        (["--pose", "0,0"], "--pose needs 1 or 6 values, got 2"),
    ],
)
def test_tolerance_option_refusals(args, message, tmp_path):
    out = cli("analyze", "tolerance", "--model", "ur5e", *args, cwd=tmp_path)
    assert one_line_error(out) == f"calibrator: error: {message}"


def test_tolerance_command_prints_and_writes_the_budget(tmp_path):
    out = cli(
        "analyze", "tolerance", "--model", "ur5e", "--poses", "6", "--samples", "60",
        "--tol", "d4=0.3", "--tol", "alpha2=0.05", "--json", "b.json", "--top", "3",
        cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    doc = json.loads((tmp_path / "b.json").read_text())
    assert doc["nominal"] == robots.get("ur5e").name and doc["poses"] == 6
    assert doc["distribution"] == "uniform" and doc["nonlinear"]["samples"] == 60
    t = {row["name"]: row for row in doc["ranking"]}
    # Overrides in mm for lengths, deg for angles (stored in rad), the rest the defaults.
    assert t["d4"]["tolerance"] == 0.3 and t["d4"]["unit"] == "mm"
    assert t["alpha2"]["tolerance"] == pytest.approx(np.radians(0.05))
    assert t["alpha2"]["unit"] == "rad"
    assert t["a3"]["tolerance"] == 0.05 and t["q1"]["tolerance"] == pytest.approx(np.radians(0.01))
    unranked = tl.without_meaning(robots.get("ur5e").mdh)  # beta of non-parallel axes
    assert sorted(t) == sorted(n for n in tl.NAMES if n not in unranked)
    lines_out = out.stdout.splitlines()
    table = lines_out[lines_out.index(next(x for x in lines_out if x.startswith("tighten"))) + 2 :]
    table = [x for x in table if not x.startswith("wrote")]
    assert [x.split()[0] for x in table] == [row["name"] for row in doc["ranking"][:3]]
    for line, row in zip(table, doc["ranking"], strict=False):
        _, value, unit, share, rms, worst = line.split()
        shown = row["tolerance"] if row["unit"] == "mm" else np.degrees(row["tolerance"])
        assert float(value) == pytest.approx(shown, abs=5e-5)
        assert unit == ("mm" if row["unit"] == "mm" else "deg")
        assert float(share[:-1]) == pytest.approx(100 * row["share"], abs=0.051)
        assert float(rms) == pytest.approx(row["rms_mm"], abs=5e-5)
        assert float(worst) == pytest.approx(row["worst_mm"], abs=5e-5)
    assert f"{doc['worst_case_mm']:9.4f} mm" in out.stdout
    assert f"{doc['rms_mm']:9.4f} mm" in out.stdout
    assert f"{doc['orientation_rms_deg']:9.5f} deg" in out.stdout
