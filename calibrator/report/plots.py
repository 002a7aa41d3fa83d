"""The report's plots as PNG bytes (matplotlib's Agg canvas; no pyplot, no global state)."""

from __future__ import annotations

import io
from collections.abc import Callable
from typing import Any

import numpy as np

from calibrator.model import parameters
from calibrator.report.data import Content, unit_of

_FIT, _HELD = "#1f77b4", "#d62728"


def draw(content: Content) -> dict[str, bytes]:
    """Every plot the content allows.

    Returns
    -------
    dict
        File name -> PNG bytes, in page order.
    """
    out = {}
    if content.poses is not None:
        out["pose_errors.png"] = png(_pose_errors, content.poses)
        out["error_cdf.png"] = png(_cdf, content.poses)
        out["error_vs_distance.png"] = png(_distance, content.poses)
    if content.convergence is not None:
        out["convergence.png"] = png(_convergence, content.convergence)
    if content.deltas:
        out["deltas.png"] = png(
            _deltas,
            content.deltas,
            content.standard_errors,
            size=(9, 1.0 + 0.2 * len(content.deltas)),
        )
    return out


def png(draw_on: Callable[..., object], *args: Any, size: tuple[float, float] = (7, 4)) -> bytes:
    """PNG bytes of a figure ``size`` inches (at 100 dpi) drawn by ``draw_on(fig, *args)``.

    Fixed margins and no software tag, so the same drawing gives the same bytes.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    # Fixed margins: matplotlib's automatic layouts cost as much as the drawing.
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.12, top=0.9, wspace=0.45)
    draw_on(fig, *args)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def _sets(poses):
    return (("fitted", ~poses.held_out, _FIT), ("held-out", poses.held_out, _HELD))


def _pose_errors(fig, poses):
    ax = fig.add_subplot()
    for label, mask, colour in _sets(poses):
        if mask.any():
            ax.scatter(
                poses.pose[mask],
                poses.before_mm[mask],
                marker="x",
                color=colour,
                alpha=0.5,
                label=f"{label}, nominal (mm)",
            )
            ax.scatter(
                poses.pose[mask],
                poses.after_mm[mask],
                marker="o",
                color=colour,
                label=f"{label}, identified (mm)",
            )
    _log_if_positive(ax, np.concatenate([poses.before_mm, poses.after_mm]))
    ax.set(xlabel="pose", ylabel="position error (mm)", title="Error per pose")
    ax.legend(fontsize="small")


def _cdf(fig, poses):
    ax = fig.add_subplot()
    for label, mask, colour in _sets(poses):
        for when, values, style in (
            ("nominal", poses.before_mm, ":"),
            ("identified", poses.after_mm, "-"),
        ):
            v = np.sort(values[mask])
            if v.size:
                ax.step(
                    v,
                    np.arange(1, v.size + 1) / v.size,
                    style,
                    where="post",
                    color=colour,
                    label=f"{label}, {when} (mm)",
                )
    _log_if_positive(ax, np.concatenate([poses.before_mm, poses.after_mm]), axis="x")
    ax.set(
        xlabel="position error (mm)",
        ylabel="share of poses",
        ylim=(0, 1.02),
        title="Cumulative distribution of the error",
    )
    ax.legend(fontsize="small")


def _distance(fig, poses):
    ax = fig.add_subplot()
    for label, mask, colour in _sets(poses):
        if mask.any():
            ax.scatter(
                poses.distance_mm[mask],
                poses.after_mm[mask],
                color=colour,
                label=f"{label} (mm)",
            )
    ax.set(
        xlabel=f"distance from the {poses.origin} (mm)",
        ylabel="position error, identified (mm)",
        title=f"Error against distance from the {poses.origin}",
    )
    ax.legend(fontsize="small")


def _convergence(fig, curve):
    ax = fig.add_subplot()
    ax.plot(curve[:, 0], curve[:, 1])
    _log_if_positive(ax, curve[:, 1])
    ax.set(xlabel="generation", ylabel="best cost (mm^2)", title="Swarm convergence")


#: Millidegrees per radian: angles in degrees, as the report's table shows them.
_MDEG = 180e3 / np.pi


def _deltas(fig, deltas, errors):
    names = list(deltas)
    # Joints and frames in panels of their own: a base offset of metres (a
    # tracker frame) would flatten joint deltas of tenths of a millimetre.
    frame = parameters.BASE_NAMES + parameters.TOOL_NAMES + parameters.TOOL_ROTATION_NAMES
    joint = [n for n in names if n not in frame]
    framed = [n for n in names if n in frame]
    groups = [
        (g, s, u, title)
        for g, s, u, title in (
            ([n for n in joint if unit_of(n) == "mm"], 1.0, "mm", "joint lengths"),
            ([n for n in joint if unit_of(n) == "rad"], _MDEG, "mdeg", "joint angles"),
            ([n for n in framed if unit_of(n) == "mm"], 1.0, "mm", "base and tool offsets"),
            ([n for n in framed if unit_of(n) == "rad"], _MDEG, "mdeg", "base and tool turns"),
        )
        if g
    ]
    # Margins in inches, not shares of the height: a short figure (few
    # parameters) must still hold the tick labels, the axis label and the title.
    height = fig.get_figheight()
    # Room above for the panel titles under the figure title.
    fig.subplots_adjust(bottom=0.55 / height, top=1 - 0.6 / height)
    axes = fig.subplots(1, len(groups), squeeze=False)[0]
    for ax, (group, scale, unit, title) in zip(axes, groups, strict=True):
        values = np.array([deltas[n] for n in group]) * scale
        xerr = None
        if errors:
            xerr = np.array([errors.get(n, np.nan) for n in group], dtype=float) * scale
        y = np.arange(len(group))
        ax.barh(y, values, xerr=xerr, color=_FIT, ecolor="black", capsize=2)
        ax.set_yticks(y, group, fontsize="small")
        ax.invert_yaxis()
        ax.axvline(0, color="grey", lw=0.5)
        ax.set(xlabel=f"delta ({unit})", title=title)
    fig.suptitle("Identified deltas" + (" with standard errors" if errors else ""))


def _log_if_positive(ax, values, axis="y"):
    values = np.asarray(values)
    if values.size and np.all(values > 0) and values.max() / values.min() > 100:
        (ax.set_yscale if axis == "y" else ax.set_xscale)("log")
