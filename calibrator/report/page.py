"""The report's HTML page: one file, images embedded, no scripts, no outside links."""

from __future__ import annotations

import base64
import html as _html
import math
from collections.abc import Mapping

from calibrator.report.data import Content, unit_of

_SECTIONS = (
    ("pose_errors", "Error per pose", "pose_errors.png"),
    ("error_cdf", "Error distribution", "error_cdf.png"),
    ("error_vs_distance", "Error against distance", "error_vs_distance.png"),
    ("convergence", "Swarm convergence", "convergence.png"),
)

#: The report pages' style sheet (the history page adds to it).
STYLE = """
body { font-family: sans-serif; max-width: 60em; margin: 2em auto; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
img { max-width: 100%; }
.note { color: #666; font-style: italic; }
.warning { color: #a40; }
.wide { overflow-x: auto; }
"""


def html(content: Content, images: Mapping[str, bytes]) -> str:
    """The page as text.

    Parameters
    ----------
    content : calibrator.report.data.Content
    images : dict
        PNG name -> bytes, as :func:`calibrator.report.plots.draw` returns.
    """
    esc = _html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(content.title)}</title><style>{STYLE}</style></head><body>",
        f"<h1>{esc(content.title)}</h1>",
        '<section id="summary"><h2>Summary</h2><table>',
        *(f"<tr><th>{esc(k)}</th><td>{esc(str(v))}</td></tr>" for k, v in content.facts),
        "</table>",
        *(f'<p class="warning">warning: {esc(w)}</p>' for w in content.warnings),
        "</section>",
        '<section id="accuracy"><h2>Accuracy</h2>',
        _stats_table(content.stats),
        "</section>",
    ]
    for key, title, name in _SECTIONS:
        parts.append(f'<section id="{key}"><h2>{title}</h2>')
        parts.append(image(images, name, title, content.notes.get(key)))
        if key == "error_vs_distance" and content.poses and content.poses.origin != "tracker":
            parts.append(
                '<p class="note">The session is in the robot base frame, where the '
                "tracker's position is not recorded: distances are from the robot base.</p>"
            )
        parts.append("</section>")
    parts.append('<section id="deltas"><h2>Identified parameters</h2>')
    if content.standard_errors is None:
        parts.append('<p class="note">standard errors: not recorded</p>')
    parts.append(image(images, "deltas.png", "Identified deltas", "no free parameters"))
    parts.append(_parameters_table(content.parameters, content.deltas, content.standard_errors))
    parts.append("</section>")
    parts.append('<section id="dropped"><h2>Parameters not identified</h2>')
    if content.dropped:
        parts.append('<table><tr><th>parameter</th><th style="text-align:left">reason</th></tr>')
        parts += [
            f'<tr><td>{esc(d["name"])}</td><td style="text-align:left">{esc(d["reason"])}</td></tr>'
            for d in content.dropped
        ]
        parts.append("</table>")
    else:
        parts.append('<p class="note">none</p>')
    parts.append("</section></body></html>")
    return "\n".join(parts) + "\n"


def image(images: Mapping[str, bytes], name: str, alt: str, note: str | None) -> str:
    """An ``<img>`` embedding ``images[name]`` (PNG bytes), or ``note`` when there is none."""
    if name not in images:
        return f'<p class="note">{_html.escape(note or "not available")}</p>'
    data = base64.b64encode(images[name]).decode("ascii")
    return f'<img src="data:image/png;base64,{data}" alt="{_html.escape(alt)}">'


def _stats_table(stats):
    rows = ["<table><tr><th></th><th>poses</th><th>mean</th><th>std</th><th>max</th></tr>"]
    for part, title in (("fit", "fitted"), ("validation", "held-out")):
        entry = stats.get(part) or {}
        before, after = entry.get("before") or {}, entry.get("after") or {}
        if not before.get("n"):
            rows.append(f"<tr><td>{title} poses</td><td>0</td><td colspan=3>none</td></tr>")
            continue
        for label, key, sub in _quantities(before):
            for when, s in (("nominal", before), ("identified", after)):
                values = s[key] if sub is None else s[key][sub]
                rows.append(
                    f"<tr><td>{title}: {label}, {when}</td><td>{s['n']}</td>"
                    + "".join(f"<td>{values[q]:.4f}</td>" for q in ("mean", "std", "max"))
                    + "</tr>"
                )
    rows.append("</table>")
    return "\n".join(rows)


def _quantities(entry):
    yield "position (mm)", "position_mm", None
    for axis in ("x", "y", "z") if "orientation_deg" in entry else ():
        yield f"orientation {axis.upper()} (deg)", "orientation_deg", axis


def _parameters_table(records, deltas, errors):
    """Nominal, identified, delta and standard error of each free parameter, mm and deg.

    ``records`` (:meth:`calibrator.calibration.Calibration.parameter_records`)
    give nominal and identified values; a name without a record (a newer
    parameter kind) still gets its delta. Every number of one unit is shown
    to the same decimals (:func:`_decimals`), so a column reads down evenly.
    """
    if not deltas:
        return ""
    known = {r["name"]: r for r in records}
    errors = errors or {}
    places = {
        unit: _decimals([errors.get(n) for n in deltas if unit_of(n) == unit], unit)
        for unit in ("mm", "rad")
    }
    rows = [
        "<table><tr><th>parameter</th><th>unit</th><th>nominal</th><th>identified</th>"
        "<th>delta</th><th>standard error</th></tr>"
    ]
    for name, value in deltas.items():
        kind = unit_of(name)
        scale, unit = (_DEG_PER_RAD, "deg") if kind == "rad" else (1.0, "mm")
        digits = places[kind]

        def fixed(v, scale=scale, digits=digits):
            return f"{v * scale + 0.0:.{digits}f}"  # + 0.0: no "-0.000"

        rec = known.get(name)
        nominal = "" if rec is None else fixed(rec["nominal"])
        identified = "" if rec is None else fixed(rec["identified"])
        err = errors.get(name)
        err_text = "not recorded" if err is None else fixed(err)
        rows.append(
            f"<tr><td>{name}</td><td>{unit}</td><td>{nominal}</td><td>{identified}</td>"
            f"<td>{fixed(value)}</td><td>{err_text}</td></tr>"
        )
    rows.append("</table>")
    rows.append(
        '<p class="note">Angles in degrees, lengths in mm, each to the decimals that show '
        "two digits of its smallest standard error. A frame delta (base_*, tool_*) is "
        "the move from the first guess expressed in the first-guess frame, as in "
        "calibration.json and the CSV export.</p>"
    )
    return "\n".join(rows)


#: Degrees per radian: the report shows angles as an engineer reads them.
_DEG_PER_RAD = 180.0 / math.pi
#: Decimals without standard errors: 0.1 um and 0.01 mdeg.
_DEFAULT_DECIMALS = {"mm": 4, "rad": 5}


def _decimals(errors, unit):
    """Decimals that show two significant digits of the smallest standard error.

    ``errors`` in mm or rad (``unit``); shown in mm or deg. Without any, a
    default per unit; never more than 9.
    """
    scale = _DEG_PER_RAD if unit == "rad" else 1.0
    known = [abs(e) * scale for e in errors if e is not None and e > 0 and math.isfinite(e)]
    if not known:
        return _DEFAULT_DECIMALS[unit]
    return int(min(max(1 - math.floor(math.log10(min(known))), 0), 9))
