"""The misalignment figures show the study's data: read back from the matplotlib figures.

Each plotting function builds a figure and hands it to ``plots._png``; the
tests put a recorder there (no rendering, so they stay fast) and compare what
the axes hold with histograms computed here, with numpy, from the trials'
raw errors (:func:`misalignment.simulate_block`). One test renders for real
and checks the PNG.
"""

import struct

import numpy as np
import pytest

from calibrator.analysis import arm, engine, plots
from calibrator.analysis import misalignment as mc

PLANES = ((0, 1), (0, 2), (1, 2))


@pytest.fixture
def figures(monkeypatch):
    """The figures the plotting functions build, in order; each returns a token instead of a PNG."""
    seen = []

    def record(fig):
        seen.append(fig)
        return f"figure {len(seen)}".encode()

    monkeypatch.setattr(plots, "_png", record)
    return seen


def small_study(r0=0.05, seed=3, trials=1500):
    """A one-block study, its merged summary and grid, and its trials' raw errors."""
    study = mc.Study(arm.build(), r0, mc.PAPER_H_MM, trials, seed)
    summary, grid = engine.run(study)
    dp, rotvec, axis = mc.simulate_block(study, 0)
    return summary, grid, dp, rotvec, axis


def lines_by_label(ax):
    return {line.get_label(): line for line in ax.lines}


def legend_labels(ax):
    legend = ax.get_legend()
    return [t.get_text() for t in legend.get_texts()] if legend is not None else []


def check_layout(fig, ncols):
    """Panels left to right, inside the figure, apart, and filling most of it."""
    boxes = [ax.get_position() for ax in fig.axes]
    assert len(boxes) == ncols
    for box in boxes:
        assert 0.0 < box.x0 < box.x1 < 1.0 and 0.0 < box.y0 < box.y1 < 1.0
    for left, right in zip(boxes, boxes[1:], strict=False):
        assert left.x1 < right.x0
    assert sum(b.width for b in boxes) > 0.6
    assert all(b.height > 0.6 for b in boxes)


def test_cloud_maps_are_the_2d_histograms_of_the_trials(figures):
    summary, grid, dp, _, _ = small_study()
    assert plots.cloud(summary, grid) == b"figure 1"
    (fig,) = figures
    check_layout(fig, 3)
    assert fig._suptitle is None
    for ax, (a, b) in zip(fig.axes, PLANES, strict=True):
        (image,) = ax.images
        counts, _, _ = np.histogram2d(
            dp[:, a],
            dp[:, b],
            bins=mc.N_GRID,
            range=[[grid.xyz_lo[a], grid.xyz_hi[a]], [grid.xyz_lo[b], grid.xyz_hi[b]]],
        )
        # Rows of the image are the vertical axis: the transposed histogram, drawn upwards.
        np.testing.assert_array_equal(image.get_array(), counts.T)
        assert image.origin == "lower"
        np.testing.assert_array_equal(
            image.get_extent(), [grid.xyz_lo[a], grid.xyz_hi[a], grid.xyz_lo[b], grid.xyz_hi[b]]
        )
        marks = lines_by_label(ax)
        # One point each: only a marker makes it visible.
        assert marks["ideal point"].get_marker() not in ("None", "", None)
        assert marks["density centre"].get_marker() not in ("None", "", None)
        np.testing.assert_array_equal(marks["ideal point"].get_xydata(), [[0.0, 0.0]])
        np.testing.assert_allclose(
            marks["density centre"].get_xydata(), [dp.mean(axis=0)[[a, b]]], rtol=1e-9
        )
        assert ax.get_xlabel() == f"d{'XYZ'[a]} (mm)" and ax.get_ylabel() == f"d{'XYZ'[b]} (mm)"
        assert ax.get_title() == f"{'XYZ'[a]}-{'XYZ'[b]} projection"
    assert legend_labels(fig.axes[0]) == ["ideal point", "density centre"]
    assert legend_labels(fig.axes[1]) == legend_labels(fig.axes[2]) == []


def test_cloud_title_gets_room_above_the_panels(figures):
    summary, grid, _, _, _ = small_study(trials=300)
    plots.cloud(summary, grid)
    plots.cloud(summary, grid, "d3=800")
    plain, titled = figures
    assert titled._suptitle.get_text() == "d3=800"
    check_layout(titled, 3)
    top = max(ax.get_position().y1 for ax in titled.axes)
    assert top < max(ax.get_position().y1 for ax in plain.axes)
    assert top < titled._suptitle.get_position()[1]


def test_pdf_and_cdf_are_those_of_the_trials_lengths(figures):
    runs = [("R0=0.025", *small_study(0.025, seed=1)), ("R0=0.05", *small_study(0.05, seed=2))]
    plots.pdf_cdf([(label, s, g) for label, s, g, *_ in runs])
    (fig,) = figures
    check_layout(fig, 2)
    ax_pdf, ax_cdf = fig.axes
    r = {label: np.sort(np.linalg.norm(dp, axis=1)) for label, _, _, dp, _, _ in runs}
    # Both curves stop at 1.4 times the larger run's 98th percentile.
    top = 1.4 * max(np.quantile(v, 0.98) for v in r.values())
    pdf_lines, cdf_lines = lines_by_label(ax_pdf), lines_by_label(ax_cdf)
    for label, summary, grid, *_ in runs:
        x, cdf = cdf_lines[label].get_xydata().T
        assert top * 0.98 <= x.max() <= top * 1.02
        assert np.all(np.diff(x) > 0) and x[0] == pytest.approx(grid.r_max / mc.N_RADIAL_BINS)
        # The share of trials whose |dP| is below each plotted length.
        below = np.searchsorted(r[label], x, side="left") / len(r[label])
        np.testing.assert_allclose(cdf, below, atol=1.5 / len(r[label]))
        x, dens = pdf_lines[label].get_xydata().T
        assert top * 0.98 <= x.max() <= top * 1.02
        # A density: it integrates to the share of trials shown, its mean is the mean |dP|,
        # its mode is the statistics' PDF peak.
        width = x[1] - x[0]
        assert np.sum(dens) * width == pytest.approx(np.mean(r[label] <= top), abs=0.01)
        assert np.sum(x * dens) * width == pytest.approx(np.mean(r[label]), rel=0.02)
        stats = mc.statistics(summary, grid)["position"]
        assert x[np.argmax(dens)] == pytest.approx(stats["pdf_peak"], abs=width)
    guides = [line.get_ydata() for line in ax_cdf.lines if line.get_label() not in r]
    assert [list(g) for g in guides] == [[0.5, 0.5], [0.9, 0.9], [0.98, 0.98]]
    assert legend_labels(ax_pdf) == ["R0=0.025", "R0=0.05"]
    assert ax_pdf.get_xlabel() == ax_cdf.get_xlabel() == "|dP| (mm)"
    assert ax_pdf.get_ylabel() == "probability density (1/mm)"
    assert ax_cdf.get_ylabel() == "cumulative probability"


def test_orientation_densities_are_the_histograms_of_the_angles(figures):
    summary, grid, _, rotvec, axis = small_study()
    plots.orientation(summary, grid)
    (fig,) = figures
    check_layout(fig, 2)
    ax_rot, ax_axis = fig.axes
    n = len(rotvec)
    for ax, values, lo, hi, names in (
        (ax_rot, rotvec, grid.rot_lo, grid.rot_hi, [f"about {c}" for c in "xyz"]),
        (ax_axis, axis, np.zeros(3), np.full(3, grid.axis_hi), [f"{c} axis" for c in "xyz"]),
    ):
        assert [line.get_label() for line in ax.lines] == names
        assert legend_labels(ax) == names
        assert ax.get_ylabel() == "probability density (1/deg)"
        for j, line in enumerate(ax.lines):
            counts, edges = np.histogram(
                np.degrees(values[:, j]),
                bins=mc.N_ANGLE_BINS,
                range=(np.degrees(lo[j]), np.degrees(hi[j])),
            )
            width = edges[1] - edges[0]
            x, dens = line.get_xydata().T
            centres = 0.5 * (edges[:-1] + edges[1:])
            np.testing.assert_allclose(x, centres, rtol=1e-9, atol=1e-9 * width)
            np.testing.assert_allclose(dens, counts / n / width, rtol=1e-9, atol=1e-9 / width)
            assert np.sum(dens) * width == pytest.approx(1.0)  # every trial inside the range
    assert ax_rot.get_xlabel() == "rotation-vector component (deg)"
    assert ax_axis.get_xlabel() == "angle between real and ideal axis (deg)"


def test_sweep_plots_each_statistic_against_the_swept_value(figures):
    keys = {"pdf_peak": "PDF peak", "cdf50": "CDF 50 %", "cdf90": "CDF 90 %", "cdf98": "CDF 98 %"}
    xs = [800.0, 1000.0, 1200.0]
    rows = [{"position": {k: (i + 1) * 0.1 + 0.01 * x for i, k in enumerate(keys)}} for x in xs]
    plots.sweep("d3 (mm)", xs, rows)
    (fig,) = figures
    check_layout(fig, 1)
    (ax,) = fig.axes
    lines = lines_by_label(ax)
    assert list(lines) == list(keys.values()) == legend_labels(ax)
    for key, label in keys.items():
        x, y = lines[label].get_xydata().T
        np.testing.assert_array_equal(x, xs)
        np.testing.assert_array_equal(y, [row["position"][key] for row in rows])
        assert lines[label].get_marker() == "o"
    assert ax.get_xlabel() == "d3 (mm)" and ax.get_ylabel() == "|dP| (mm)"
    assert ax.get_ylim()[0] == 0.0 and ax.get_ylim()[1] >= max(r["position"]["cdf98"] for r in rows)


def test_png_is_the_figure_at_its_size_and_the_same_bytes_every_time():
    summary, grid, _, _, _ = small_study(trials=200)
    fig, axes = plots._figure(2)
    axes[0].plot([0.0, 1.0], [1.0, 0.0])
    first, second = plots._png(fig), plots._png(fig)
    assert first[:8] == b"\x89PNG\r\n\x1a\n" and first[12:16] == b"IHDR"
    width, height = struct.unpack(">II", first[16:24])
    assert (width, height) == tuple(np.round(fig.get_size_inches() * fig.dpi).astype(int))
    assert first == second
    # No software version stamped in: the bytes depend on the data, not the install.
    assert b"Software" not in first and b"matplotlib" not in first.lower()
    cloud = plots.cloud(summary, grid, "title")
    width, height = struct.unpack(">II", cloud[16:24])
    assert width > 2.5 * height  # three panels side by side
