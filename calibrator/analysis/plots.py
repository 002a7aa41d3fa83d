"""PNG figures of a misalignment study, as bytes (matplotlib's Agg canvas, no pyplot).

The command writes them through :mod:`calibrator.outputs`, so they appear
whole or not at all. matplotlib is imported inside the functions.
"""

from __future__ import annotations

import io
from collections.abc import Sequence

import numpy as np

from calibrator.analysis import misalignment as mc


def _figure(ncols, width=4.2, height=3.8):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width * ncols, height), dpi=100)
    FigureCanvasAgg(fig)
    # Fixed margins: matplotlib's automatic layouts cost as much as the drawing.
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.13, top=0.88, wspace=0.3)
    return fig, [fig.add_subplot(1, ncols, i + 1) for i in range(ncols)]


def _png(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def cloud(summary: mc.Summary, grid: mc.Grid, title: str = "") -> bytes:
    """Density maps of the hand-error cloud projected on the XY, XZ and YZ planes.

    The ideal point (origin) is a cross, the density centre (mean error) a dot.
    """
    stats_mean = summary.totals()[0:3] / summary.count
    fig, axes = _figure(3)
    for ax, m, (a, b) in zip(axes, range(3), ((0, 1), (0, 2), (1, 2)), strict=True):
        extent = (grid.xyz_lo[a], grid.xyz_hi[a], grid.xyz_lo[b], grid.xyz_hi[b])
        ax.imshow(summary.maps[m].T, origin="lower", extent=extent, aspect="auto", cmap="Greys")
        ax.plot([0.0], [0.0], "r+", markersize=12, label="ideal point")
        ax.plot([stats_mean[a]], [stats_mean[b]], "b.", markersize=8, label="density centre")
        ax.set_xlabel(f"d{'XYZ'[a]} (mm)")
        ax.set_ylabel(f"d{'XYZ'[b]} (mm)")
        ax.set_title(f"{'XYZ'[a]}-{'XYZ'[b]} projection")
    axes[0].legend(loc="upper right", fontsize="small")
    if title:
        fig.subplots_adjust(top=0.8)
        fig.suptitle(title)
    return _png(fig)


def pdf_cdf(runs: Sequence[tuple[str, mc.Summary, mc.Grid]]) -> bytes:
    """PDF and CDF of |dP| for one or several runs.

    Parameters
    ----------
    runs : list of (str, Summary, Grid)
        Label, summary and grid of each run.
    """
    fig, (ax_pdf, ax_cdf) = _figure(2, width=5.0)
    top = max(mc.statistics(s, g)["position"]["cdf98"] for _, s, g in runs) * 1.4
    for label, summary, grid in runs:
        stats = mc.statistics(summary, grid)["position"]
        centres, dens = mc.radial_density(summary, grid, stats["kernel"])
        keep = centres <= top
        ax_pdf.plot(centres[keep], dens[keep], label=label)
        edges = np.linspace(0.0, grid.r_max, mc.N_RADIAL_BINS + 1)[1:]
        cdf = np.cumsum(summary.hist_r) / summary.count
        shown = edges <= top
        ax_cdf.plot(edges[shown], cdf[shown], label=label)
    for p in (0.5, 0.9, 0.98):
        ax_cdf.axhline(p, color="0.7", linewidth=0.8)
    ax_pdf.set_xlabel("|dP| (mm)")
    ax_pdf.set_ylabel("probability density (1/mm)")
    ax_cdf.set_xlabel("|dP| (mm)")
    ax_cdf.set_ylabel("cumulative probability")
    ax_pdf.legend(fontsize="small")
    return _png(fig)


def orientation(summary: mc.Summary, grid: mc.Grid) -> bytes:
    """Densities of the orientation error: rotation about hand x, y, z and axis angles (deg)."""
    fig, (ax_rot, ax_axis) = _figure(2, width=5.0)
    for j, name in enumerate("xyz"):
        edges = np.degrees(np.linspace(grid.rot_lo[j], grid.rot_hi[j], mc.N_ANGLE_BINS + 1))
        dens = summary.hist_rot[j] / summary.count / (edges[1] - edges[0])
        ax_rot.plot(0.5 * (edges[:-1] + edges[1:]), dens, label=f"about {name}")
        edges = np.degrees(np.linspace(0.0, grid.axis_hi, mc.N_ANGLE_BINS + 1))
        dens = summary.hist_axis[j] / summary.count / (edges[1] - edges[0])
        ax_axis.plot(0.5 * (edges[:-1] + edges[1:]), dens, label=f"{name} axis")
    ax_rot.set_xlabel("rotation-vector component (deg)")
    ax_axis.set_xlabel("angle between real and ideal axis (deg)")
    for ax in (ax_rot, ax_axis):
        ax.set_ylabel("probability density (1/deg)")
        ax.legend(fontsize="small")
    return _png(fig)


def sweep(xlabel: str, xs: Sequence[float], rows: Sequence[dict]) -> bytes:
    """Statistics of |dP| against a swept input (R0 or a link length)."""
    fig, (ax,) = _figure(1, width=5.5)
    for key, label in (
        ("pdf_peak", "PDF peak"),
        ("cdf50", "CDF 50 %"),
        ("cdf90", "CDF 90 %"),
        ("cdf98", "CDF 98 %"),
    ):
        ax.plot(xs, [r["position"][key] for r in rows], "o-", label=label)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("|dP| (mm)")
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize="small")
    return _png(fig)
