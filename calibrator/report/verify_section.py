"""The report's ISO 9283 verification section, from ``calibrator verify`` outputs.

``calibrator report ... --verify before.json --verify after.json`` adds one
section: the per-pose table (AP, APx, APy, APz, RP, and the orientation
figures when measured), the runs side by side in the order given, and
``verify_clouds.png``: for each test pose, each run's barycentre about the
commanded position and its attained positions about the barycentre (x-y
deviations, mm, one scale per row), read from the ``verify.parquet`` beside
each JSON. A run without its parquet is tabled and the plot says so.
Path tests (``verify --path``) among the files go to their own section
(:mod:`calibrator.report.path_section`).
"""

from __future__ import annotations

import html as _html
import io
import json
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from calibrator.errors import CalibrationError

#: The section's plot, written into the report folder.
CLOUDS_PNG = "verify_clouds.png"
_KEYS = ("AP_mm", "APx_mm", "APy_mm", "APz_mm", "RP_mm")
_ORIENTATION = ("APa_deg", "APb_deg", "APc_deg", "RPa_deg", "RPb_deg", "RPc_deg")
_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#9467bd")


@dataclass(frozen=True)
class VerifyRun:
    """One ``calibrator verify`` result.

    Attributes
    ----------
    path : Path
        The JSON file.
    doc : dict
        Its content (``poses``, ``cycles``, ``compensated``, ``registration``, ...).
    table : pandas.DataFrame or None
        The attained poses (``verify.parquet``), when beside it.
    """

    path: Path
    doc: dict
    table: pd.DataFrame | None

    @property
    def label(self) -> str:
        state = "after (compensated)" if self.doc.get("compensated") else "before (nominal)"
        return f"{state}: {self.path.name}"


def data_paths(paths: Iterable[str | os.PathLike[str]] | None) -> list[Path]:
    """The parquet files the JSON files name (inputs the report must not overwrite)."""
    out = []
    for path in paths or ():
        out.append(Path(path).with_suffix(".parquet"))
    return out


def load(paths: Iterable[str | os.PathLike[str]] | None) -> list[VerifyRun]:
    """Read verify.json files (and their parquet files when present).

    Raises
    ------
    CalibrationError
        A file that is missing, not JSON, or not a ``calibrator verify`` result.
    """
    runs = []
    for path in paths or ():
        path = Path(path)
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise CalibrationError(f"--verify {path}: file not found") from None
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            raise CalibrationError(f"--verify {path}: not a readable JSON file ({exc})") from None
        from calibrator.report import path_section

        if (
            isinstance(doc, dict)
            and doc.get("format") == "calibrator.verify"
            and path_section.is_path(doc)
        ):
            # A path test (verify --path): its own section, its stream not read.
            path_section.validate(doc, str(path))
            runs.append(VerifyRun(path, doc, None))
            continue
        poses = doc.get("poses") if isinstance(doc, dict) else None
        if (
            not isinstance(doc, dict)
            or doc.get("format") != "calibrator.verify"
            or not isinstance(poses, list)
            or [p.get("test_pose") if isinstance(p, dict) else None for p in poses]
            != [1, 2, 3, 4, 5]
            or not all(isinstance(p.get(k), int | float) for p in poses for k in _KEYS)
        ):
            raise CalibrationError(
                f"--verify {path}: not a calibrator verify result (needs format "
                "'calibrator.verify' and poses 1..5 with AP_mm..RP_mm)"
            )
        table = None
        data = path.parent / str(doc.get("data") or path.with_suffix(".parquet").name)
        if data.is_file():
            try:
                table = pd.read_parquet(data)
            except (OSError, ValueError) as exc:
                raise CalibrationError(f"--verify {data}: unreadable ({exc})") from None
        runs.append(VerifyRun(path, doc, table))
    return runs


def section_html(runs: list[VerifyRun], images: dict) -> str:
    """The section as HTML (table, then the clouds plot or why it is missing)."""
    esc = _html.escape
    parts = ['<section id="verify"><h2>ISO 9283 pose accuracy and repeatability</h2>']
    for i, run in enumerate(runs):
        reg = run.doc.get("registration", {})
        parts.append(
            f"<p>{i + 1}: {esc(run.label)}; {run.doc.get('cycles')} cycles, frame "
            f"{esc(str(run.doc.get('frame', 'robot base')))}, registration "
            f"{esc(str(reg.get('method')))} ({esc(str(reg.get('source')))}); orientation "
            f"{esc(str(run.doc.get('orientation', 'not measured')))}</p>"
        )
    keys = list(_KEYS)
    if all(_ORIENTATION[0] in run.doc["poses"][0] for run in runs):
        keys += _ORIENTATION
    names = [f"{i + 1}: {run.label.split(':')[0]}" for i, run in enumerate(runs)]
    # One row per pose and run, one column per figure: as narrow as the page for
    # any number of runs (a column per run and figure overflowed it).
    head = "".join(f"<th>{esc(k)}</th>" for k in keys)
    parts.append(f'<div class="wide"><table><tr><th>test pose</th><th>run</th>{head}</tr>')
    for k in range(5):
        for name, run in zip(names, runs, strict=True):
            cells = "".join(f"<td>{run.doc['poses'][k][key]:.4f}</td>" for key in keys)
            parts.append(f"<tr><td>P{k + 1}</td><td>{esc(name)}</td>{cells}</tr>")
    parts.append("</table></div>")
    if CLOUDS_PNG in images:
        import base64

        data = base64.b64encode(images[CLOUDS_PNG]).decode("ascii")
        parts.append(f'<img src="data:image/png;base64,{data}" alt="attained clouds">')
    else:
        parts.append(
            '<p class="note">attained clouds: give the verify.parquet beside each JSON</p>'
        )
    parts.append("</section>")
    return "\n".join(parts)


def clouds_png(runs: list[VerifyRun]) -> bytes:
    """:func:`clouds_figure` as PNG bytes."""
    buf = io.BytesIO()
    clouds_figure(runs).savefig(buf, format="png", metadata={"Software": None})
    return buf.getvalue()


def clouds_figure(runs: list[VerifyRun]) -> Any:
    """Accuracy and repeatability of each test pose, every panel of a row at one scale.

    Top row: each run's barycentre of the attained positions, x-y deviation
    from the commanded position (AP). Bottom row: each attained position about
    its run's barycentre (RP). One scale per row, so panels compare; the
    repeatability row has its own, so its clouds are not dots beside a
    millimetre offset.

    Returns
    -------
    matplotlib.figure.Figure
        Ten panels: ``axes[k]`` the barycentres at P(k+1), ``axes[5 + k]`` the cloud.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12, 6.0), dpi=100)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=0.07, right=0.99, bottom=0.09, top=0.88, wspace=0.35, hspace=0.45)
    deviations = [[_deviations(run, k) for k in range(5)] for run in runs]
    centres = [[(dx.mean(), dy.mean()) for dx, dy in row] for row in deviations]
    reach = max(max(abs(c) for xy in row for c in xy) for row in centres) * 1.15 or 1e-3
    spread = (
        max(
            max(np.abs(dx - dx.mean()).max(), np.abs(dy - dy.mean()).max())
            for row in deviations
            for dx, dy in row
        )
        * 1.15
        or 1e-3
    )
    tops = [fig.add_subplot(2, 5, k + 1) for k in range(5)]
    bottoms = [fig.add_subplot(2, 5, k + 6) for k in range(5)]
    for k, (top, bottom) in enumerate(zip(tops, bottoms, strict=True)):
        for i, (run, colour) in enumerate(zip(runs, _COLOURS, strict=False)):
            dx, dy = deviations[i][k]
            cx, cy = centres[i][k]
            top.scatter([cx], [cy], marker="x", s=40, color=colour, label=run.label)
            bottom.scatter(dx - cx, dy - cy, s=6, color=colour)
        top.scatter([0.0], [0.0], marker="+", s=80, color="black", label="commanded")
        for ax, half in ((top, reach), (bottom, spread)):
            ax.set_xlim(-half, half)
            ax.set_ylim(-half, half)
            ax.set_aspect("equal")
            ax.tick_params(labelsize="small")
        top.set_title(f"P{k + 1}: barycentre")
        bottom.set_title(f"P{k + 1}: about it")
        bottom.set_xlabel("x (mm)")
        if k == 0:
            top.set_ylabel("y deviation from\ncommanded (mm)")
            bottom.set_ylabel("y deviation from\nbarycentre (mm)")
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=len(labels), fontsize="small")
    return fig


def _deviations(run: VerifyRun, k: int) -> tuple[np.ndarray, np.ndarray]:
    """x and y of the attained positions at test pose ``k + 1`` less the commanded, mm."""
    assert run.table is not None  # add() draws only when every run has its table
    rows = run.table[run.table["test_pose"] == k + 1]
    dx = rows["x_mm"].to_numpy() - rows["cmd_x_mm"].to_numpy()
    dy = rows["y_mm"].to_numpy() - rows["cmd_y_mm"].to_numpy()
    return dx, dy


def add(html: str, runs: list[VerifyRun]) -> tuple[str, dict]:
    """Insert the section at the end of a report page.

    Returns
    -------
    html : str
    images : dict
        ``{CLOUDS_PNG: bytes}`` when every run has its parquet, else empty.
    """
    from calibrator.report import path_section

    paths = [run for run in runs if path_section.is_path(run.doc)]
    runs = [run for run in runs if not path_section.is_path(run.doc)]
    images: dict = {}
    if runs:
        if all(run.table is not None for run in runs):
            images[CLOUDS_PNG] = clouds_png(runs)
        section = section_html(runs, images)
        end = html.rfind("</body>")
        html = html[:end] + section + "\n" + html[end:]
    if paths:  # verify --path results: the path section after the pose test's
        html, more = path_section.add(html, paths)
        images.update(more)
    return html, images
