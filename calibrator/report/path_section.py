"""The report's ISO 9283 path section, from ``calibrator verify --path`` outputs.

``calibrator report ... --verify line_before.json --verify line_after.json``
with path tests among the files adds this section beside the pose test's: a
table of each run's clause 7 figures (AT_P, RT_P, AV, RV, FV, and the worst
corner's CR and CO for a rectangle), with its shape, speed (and share of the
rated speed), cycles and commands, the orientation figures AT_a..RT_c
(degrees) when a run's probe gave its orientation (a 6-DoF probe; blank for a
reflector's run), and ``verify_path.png``: each run's path
accuracy ``AT_i`` at the calculated points along the path (mm over the arc
length, mm), where a calibration's gain or a fault's place along the path shows.
"""

from __future__ import annotations

import html as _html
import io
from typing import Any

import numpy as np

from calibrator.errors import CalibrationError

#: The section's plot, written into the report folder.
PATH_PNG = "verify_path.png"
#: The figures every path test has, in the table's order, with their units.
FIGURES = (("AT_P_mm", "AT_P mm"), ("RT_P_mm", "RT_P mm"), ("AV_pct", "AV %"),
           ("RV_pct", "RV %"), ("FV_mm_s", "FV mm/s"))  # fmt: skip
#: The orientation figures a 6-DoF probe adds (degrees); a reflector's run leaves them blank.
ORIENTATION = tuple((f"{k}{x}_deg", f"{k}_{x} deg") for k in ("AT", "RT") for x in "abc")
_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd")


def is_path(doc: object) -> bool:
    """Whether a verify document is a path test's (``test: path``)."""
    return isinstance(doc, dict) and doc.get("test") == "path"


def validate(doc: dict, where: str) -> None:
    """Refuse a path document without its figures (one line, naming the file).

    Raises
    ------
    CalibrationError
    """
    path = doc.get("path")
    ok = isinstance(path, dict) and all(isinstance(path.get(k), int | float) for k, _ in FIGURES)
    points = path.get("points") if isinstance(path, dict) else None
    if not ok or not isinstance(points, dict) or not isinstance(points.get("AT_mm"), list):
        raise CalibrationError(
            f"--verify {where}: a path test without its figures (needs path.AT_P_mm.."
            "FV_mm_s and path.points)"
        )


def _label(run: Any) -> str:
    path = run.doc["path"]
    state = "after (compensated)" if path.get("compensated") else "before (nominal)"
    return f"{state}: {run.path.name}"


def section_html(runs: list, images: dict) -> str:
    """The section as HTML: one table row per run, then the plot."""
    esc = _html.escape
    parts = ['<section id="verify-path"><h2>ISO 9283 path accuracy (clause 7)</h2>']
    corners = any("CR_mm" in run.doc["path"] for run in runs)
    head = "".join(f"<th>{esc(name)}</th>" for _, name in FIGURES)
    if corners:
        head += "<th>CR max mm</th><th>CO max mm</th>"
    oriented = any(run.doc["path"].get("ATa_deg") is not None for run in runs)
    if oriented:
        head += "".join(f"<th>{esc(name)}</th>" for _, name in ORIENTATION)
    parts.append(
        '<div class="wide"><table><tr><th>run</th><th>shape</th><th>speed mm/s</th>'
        f"<th>% of rated</th><th>cycles</th>{head}</tr>"
    )
    for i, run in enumerate(runs):
        path = run.doc["path"]
        pct = path.get("speed_pct")
        cells = "".join(f"<td>{path[key]:.4f}</td>" for key, _ in FIGURES)
        if corners:
            cr, co = path.get("CR_mm"), path.get("CO_mm")
            cells += f"<td>{max(cr):.4f}</td><td>{max(co):.4f}</td>" if cr else "<td></td><td></td>"
        if oriented:
            cells += "".join(_degrees(path.get(key)) for key, _ in ORIENTATION)
        parts.append(
            f"<tr><td>{i + 1}: {esc(_label(run))}</td><td>{esc(str(path.get('shape')))}</td>"
            f"<td>{float(path.get('speed_mm_s', np.nan)):.1f}</td>"
            f"<td>{'' if pct is None else f'{pct:.0f}'}</td>"
            f"<td>{path.get('cycles')}</td>{cells}</tr>"
        )
    parts.append("</table></div>")
    if PATH_PNG in images:
        import base64

        data = base64.b64encode(images[PATH_PNG]).decode("ascii")
        parts.append(f'<img src="data:image/png;base64,{data}" alt="path accuracy along the path">')
    parts.append("</section>")
    return "\n".join(parts)


def _degrees(value: object) -> str:
    """A table cell of an orientation figure (deg); blank when the run has none."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return f"<td>{value:.4f}</td>"
    return "<td></td>"


def path_figure(runs: list) -> Any:
    """Each run's ``AT_i`` (mm) over the arc length of its calculated points (mm), one axes.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 3.6), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for i, (run, colour) in enumerate(zip(runs, _COLOURS * len(runs), strict=False)):
        points = run.doc["path"]["points"]
        s = points.get("s_mm") or list(range(len(points["AT_mm"])))
        ax.plot(s, points["AT_mm"], color=colour, label=f"{i + 1}: {_label(run)}")
    ax.set_xlabel("along the path (mm)")
    ax.set_ylabel("AT at the point (mm)")
    ax.set_ylim(bottom=0.0)
    ax.legend(fontsize="small")
    fig.tight_layout()
    return fig


def path_png(runs: list) -> bytes:
    """:func:`path_figure` as PNG bytes."""
    buf = io.BytesIO()
    path_figure(runs).savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def add(html: str, runs: list) -> tuple[str, dict]:
    """Insert the section at the end of a report page; ``{PATH_PNG: bytes}`` with it."""
    images = {PATH_PNG: path_png(runs)}
    section = section_html(runs, images)
    end = html.rfind("</body>")
    return html[:end] + section + "\n" + html[end:], images
