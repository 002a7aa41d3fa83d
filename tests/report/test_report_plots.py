"""The report's plots show the numbers they claim: read back from matplotlib's Figure objects."""

import struct
from dataclasses import replace

import numpy as np
import pytest
from matplotlib.colors import to_rgba
from matplotlib.container import BarContainer
from matplotlib.figure import Figure
from matplotlib.markers import MarkerStyle
from report_kit import content

from calibrator.report import data, plots

FIT, HELD = to_rgba("#1f77b4"), to_rgba("#d62728")

#: Millidegrees per radian: the report's angles are in degrees.
MDEG = 180e3 / np.pi


def _recorder(monkeypatch, render):
    saved = []
    real = Figure.savefig

    def savefig(self, *args, **kwargs):
        saved.append(self)
        if render:
            real(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return saved


@pytest.fixture
def figures(monkeypatch):
    """Every Figure the plots make, in order, left unrendered (the checks read its artists)."""
    return _recorder(monkeypatch, render=False)


@pytest.fixture
def rendered(monkeypatch):
    """Every Figure the plots make, in order, rendered to PNG as usual."""
    return _recorder(monkeypatch, render=True)


def poses(origin="tracker", held=(False, True, False, False, True), scale=1.0):
    before = np.array([4.0, 2.0, 3.0, 5.0, 1.5]) * scale
    return data.PoseErrors(
        pose=np.array([3, 5, 7, 9, 11]),
        held_out=np.array(held),
        before_mm=before,
        after_mm=np.array([0.2, 0.6, 0.1, 0.3, 0.5]) * scale,
        distance_mm=np.array([2500.0, 2600.0, 2700.0, 2800.0, 2900.0]),
        origin=origin,
    )


def png_size(png):
    assert png.startswith(b"\x89PNG\r\n\x1a\n")
    return struct.unpack(">II", png[16:24])


def marker_path(name):
    style = MarkerStyle(name)
    return style.get_path().transformed(style.get_transform()).vertices


def legend(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_draw_makes_each_plot_the_content_allows_in_page_order(figures):
    full = content(
        poses=poses(),
        convergence=np.array([[0, 9.0], [1, 4.0]]),
        deltas={"a1": 0.1},
    )
    assert list(plots.draw(full)) == [
        "pose_errors.png",
        "error_cdf.png",
        "error_vs_distance.png",
        "convergence.png",
        "deltas.png",
    ]
    assert len(figures) == 5
    assert plots.draw(content()) == {}
    assert list(plots.draw(content(deltas={"a1": 0.1}))) == ["deltas.png"]
    only_curve = content(convergence=np.array([[0, 1.0]]))
    assert list(plots.draw(only_curve)) == ["convergence.png"]


def test_images_are_pngs_of_the_figure_size_and_the_same_every_time(rendered):
    two = content(convergence=np.array([[0, 9.0], [1, 4.0]]), deltas={"a1": 0.1, "d2": 0.2})
    images = plots.draw(two)
    assert png_size(images["convergence.png"]) == (700, 400)  # 7 x 4 in at 100 dpi
    assert png_size(images["deltas.png"]) == (900, 100 * (1.0 + 0.2 * 2))
    for png in images.values():
        assert b"Software" not in png  # no matplotlib version stamp: same bytes every run
    assert plots.draw(two) == images


@pytest.mark.parametrize("n", [1, 2, 30])
def test_nothing_drawn_falls_outside_the_image(rendered, n):
    deltas = {f"theta{i + 1}": 0.001 * (i + 1) for i in range(n - 1)} | {"a2": 0.3}
    full = content(poses=poses(), convergence=np.array([[0, 9.0], [1, 4.0]]), deltas=deltas)
    plots.draw(full)
    for fig in rendered:
        drawn = fig.get_tightbbox(fig.canvas.get_renderer())  # inches, labels included
        width, height = fig.get_size_inches()
        assert 0 <= drawn.x0 and drawn.x1 <= width, (fig.get_suptitle(), drawn)
        assert 0 <= drawn.y0 and drawn.y1 <= height, (fig.get_suptitle(), drawn)


def test_error_per_pose_plots_each_set_before_and_after(figures):
    p = poses()
    plots.draw(content(poses=p))
    (ax,) = figures[0].axes
    fit, held = ~p.held_out, p.held_out
    expected = [
        (fit, p.before_mm, FIT, "x", 0.5, "fitted, nominal (mm)"),
        (fit, p.after_mm, FIT, "o", None, "fitted, identified (mm)"),
        (held, p.before_mm, HELD, "x", 0.5, "held-out, nominal (mm)"),
        (held, p.after_mm, HELD, "o", None, "held-out, identified (mm)"),
    ]
    assert len(ax.collections) == 4
    for coll, (mask, values, colour, marker, alpha, label) in zip(
        ax.collections, expected, strict=True
    ):
        np.testing.assert_array_equal(
            coll.get_offsets(), np.column_stack([p.pose[mask], values[mask]])
        )
        assert coll.get_label() == label
        assert coll.get_alpha() == alpha
        np.testing.assert_allclose(coll.get_facecolor()[0][:3], colour[:3])
        np.testing.assert_allclose(coll.get_paths()[0].vertices, marker_path(marker))
    assert legend(ax) == [e[-1] for e in expected]
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) == (
        "pose",
        "position error (mm)",
        "Error per pose",
    )
    assert ax.get_yscale() == "linear"  # 0.1 .. 5 mm: a factor 50


def test_a_set_without_poses_is_left_out(figures):
    p = poses(held=(False,) * 5)
    plots.draw(content(poses=p))
    pose_ax, cdf_ax, distance_ax = (f.axes[0] for f in figures)
    assert [c.get_label() for c in pose_ax.collections] == [
        "fitted, nominal (mm)",
        "fitted, identified (mm)",
    ]
    assert [line.get_label() for line in cdf_ax.lines] == [
        "fitted, nominal (mm)",
        "fitted, identified (mm)",
    ]
    assert [c.get_label() for c in distance_ax.collections] == ["fitted (mm)"]


def test_error_scale_turns_logarithmic_past_a_factor_of_100(figures):
    base = poses()
    wide = replace(base, after_mm=base.after_mm / 100)  # 0.001 .. 5 mm
    exactly = replace(
        base,
        before_mm=np.array([10.0, 1.0, 1.0, 1.0, 1.0]),
        after_mm=np.array([0.1, 0.2, 0.3, 0.4, 0.5]),  # max / min == 100
    )
    zero = replace(base, after_mm=np.array([0.0, 1e-3, 1e-3, 1e-3, 1e-3]))
    negative = replace(base, after_mm=-base.after_mm)
    for p, scale in ((wide, "log"), (exactly, "linear"), (zero, "linear"), (negative, "linear")):
        figures.clear()
        plots.draw(content(poses=p))
        assert figures[0].axes[0].get_yscale() == scale  # error per pose
        assert figures[1].axes[0].get_xscale() == scale  # distribution
        assert figures[1].axes[0].get_yscale() == "linear"
        assert figures[2].axes[0].get_yscale() == "linear"  # against distance: never log


def test_distribution_is_a_step_per_set_and_model_rising_to_one(figures):
    p = poses()
    plots.draw(content(poses=p))
    ax = figures[1].axes[0]
    expected = [
        (~p.held_out, p.before_mm, FIT, ":", "fitted, nominal (mm)"),
        (~p.held_out, p.after_mm, FIT, "-", "fitted, identified (mm)"),
        (p.held_out, p.before_mm, HELD, ":", "held-out, nominal (mm)"),
        (p.held_out, p.after_mm, HELD, "-", "held-out, identified (mm)"),
    ]
    assert len(ax.lines) == 4
    for line, (mask, values, colour, style, label) in zip(ax.lines, expected, strict=True):
        n = mask.sum()
        np.testing.assert_array_equal(line.get_xdata(), np.sort(values[mask]))
        np.testing.assert_allclose(line.get_ydata(), np.arange(1, n + 1) / n)
        assert line.get_drawstyle() == "steps-post"
        assert line.get_linestyle() == style
        assert to_rgba(line.get_color()) == colour
        assert line.get_label() == label
    assert legend(ax) == [e[-1] for e in expected]
    assert ax.get_ylim() == (0, 1.02)
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) == (
        "position error (mm)",
        "share of poses",
        "Cumulative distribution of the error",
    )


@pytest.mark.parametrize("origin", ["tracker", "robot base"])
def test_error_against_distance_from_the_named_origin(figures, origin):
    p = poses(origin=origin)
    plots.draw(content(poses=p))
    ax = figures[2].axes[0]
    assert len(ax.collections) == 2
    for coll, mask, colour, label in zip(
        ax.collections,
        (~p.held_out, p.held_out),
        (FIT, HELD),
        ("fitted (mm)", "held-out (mm)"),
        strict=True,
    ):
        np.testing.assert_array_equal(
            coll.get_offsets(), np.column_stack([p.distance_mm[mask], p.after_mm[mask]])
        )
        np.testing.assert_allclose(coll.get_facecolor()[0][:3], colour[:3])
        assert coll.get_label() == label
    assert legend(ax) == ["fitted (mm)", "held-out (mm)"]
    assert ax.get_xlabel() == f"distance from the {origin} (mm)"
    assert ax.get_ylabel() == "position error, identified (mm)"
    assert ax.get_title() == f"Error against distance from the {origin}"


def test_convergence_curve_is_plotted_as_recorded(figures):
    curve = np.array([[0.0, 900.0], [10.0, 40.0], [20.0, 8.0]])  # a factor 112.5: log
    plots.draw(content(convergence=curve))
    (ax,) = figures[0].axes
    (line,) = ax.lines
    np.testing.assert_array_equal(line.get_xdata(), curve[:, 0])
    np.testing.assert_array_equal(line.get_ydata(), curve[:, 1])
    assert ax.get_yscale() == "log"
    assert (ax.get_xlabel(), ax.get_ylabel(), ax.get_title()) == (
        "generation",
        "best cost (mm^2)",
        "Swarm convergence",
    )
    for top, scale in ((100.0, "linear"), (100.5, "log")):  # log only past a factor 100
        figures.clear()
        plots.draw(content(convergence=np.array([[0.0, top], [1.0, 1.0]])))
        assert figures[0].axes[0].get_yscale() == scale


def _bars(ax):
    (bars,) = (c for c in ax.containers if isinstance(c, BarContainer))
    return [rect.get_width() for rect in bars.patches], bars


def test_deltas_are_bars_in_mm_and_mdeg_with_their_standard_errors(figures):
    deltas = {"a1": 0.25, "theta2": -0.002, "d3": -0.5, "tool_rx": 0.001}
    errors = {"a1": 0.05, "theta2": 0.0004, "tool_rx": 0.0002}  # none for d3
    plots.draw(content(deltas=deltas, standard_errors=errors))
    (fig,) = figures
    assert tuple(fig.get_size_inches()) == pytest.approx((9, 1.0 + 0.2 * 4))
    assert fig.get_suptitle() == "Identified deltas with standard errors"
    # Joints and frames in panels of their own: a frame's metres never flatten a joint's.
    lengths, angles, turns = fig.axes
    for ax, names, scale, unit, title in (
        (lengths, ["a1", "d3"], 1.0, "mm", "joint lengths"),
        (angles, ["theta2"], MDEG, "mdeg", "joint angles"),
        (turns, ["tool_rx"], MDEG, "mdeg", "base and tool turns"),
    ):
        assert ax.get_title() == title
        widths, bars = _bars(ax)
        np.testing.assert_allclose(widths, [deltas[n] * scale for n in names])
        assert [t.get_text() for t in ax.get_yticklabels()] == names
        np.testing.assert_array_equal(ax.get_yticks(), np.arange(len(names)))
        assert ax.yaxis_inverted()  # first parameter on top
        assert ax.get_xlabel() == f"delta ({unit})"
        _, caps, (whiskers,) = bars.errorbar.lines
        # A missing standard error is NaN: no whisker drawn for that bar.
        half = [(s[1, 0] - s[0, 0]) / 2 if len(s) else np.nan for s in whiskers.get_segments()]
        np.testing.assert_allclose(half, [errors.get(n, np.nan) * scale for n in names])
        np.testing.assert_allclose(whiskers.get_color()[0], to_rgba("black"))
        assert caps and all(cap.get_markersize() == 4 for cap in caps)  # capsize 2 pt
        assert any(
            list(line.get_xdata()) == [0, 0] and line.get_color() == "grey" for line in ax.lines
        )
        for rect in bars.patches:
            assert to_rgba(rect.get_facecolor()) == FIT


def test_deltas_without_standard_errors_or_of_one_kind(figures):
    plots.draw(content(deltas={"alpha1": 0.001, "beta2": -0.003}))
    (fig,) = figures
    assert fig.get_suptitle() == "Identified deltas"
    (ax,) = fig.axes
    widths, bars = _bars(ax)
    np.testing.assert_allclose(widths, [1.0 * MDEG / 1e3, -3.0 * MDEG / 1e3])
    assert ax.get_xlabel() == "delta (mdeg)"
    assert bars.errorbar is None
    assert tuple(fig.get_size_inches()) == pytest.approx((9, 1.4))


def test_joint_deltas_stay_visible_beside_metre_scale_base_offsets(figures):
    plots.draw(content(deltas={"a2": 0.1, "d4": -0.05, "base_tx": 1500.0, "base_rz": 0.2}))
    (fig,) = figures
    joints, offsets, turns = fig.axes
    assert [t.get_text() for t in joints.get_yticklabels()] == ["a2", "d4"]
    assert [t.get_text() for t in offsets.get_yticklabels()] == ["base_tx"]
    assert max(abs(v) for v in joints.get_xlim()) < 1.0  # a 0.1 mm bar fills its panel
    assert offsets.get_title() == "base and tool offsets" and turns.get_xlabel() == "delta (mdeg)"
