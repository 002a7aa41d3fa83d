"""The history page of one robot: one HTML file, plots embedded, as the calibration report.

Reuses the report's style, image embedding and PNG drawing
(:mod:`calibrator.report.page`, :mod:`calibrator.report.plots`).
"""

from __future__ import annotations

import html as _html
from collections.abc import Sequence
from typing import Any

from calibrator.history.alarms import Alarm, Limits, explanations
from calibrator.history.timeline import Timeline, table
from calibrator.report import page as report_page
from calibrator.report import plots as report_plots
from calibrator.report.data import unit_of

_ESC = _html.escape
_ALARM_STYLE = ".alarm { color: #b00; font-weight: bold; } td.text { text-align: left; }"


def images(data: Timeline, limits: Limits) -> dict[str, bytes]:
    """The page's plots (PNG bytes by name); a plot without data is left out."""
    out = {}
    if data.calibrations or data.checks:
        out["held_out.png"] = report_plots.png(_held_out, data, limits)
    if data.verifications:
        out["iso9283.png"] = report_plots.png(_iso, data.verifications)
    names = sorted({n for c in data.calibrations for n in c["parameters"]}, key=_order)
    if names:
        rows = -(-len(names) // 4)
        out["parameters.png"] = report_plots.png(
            _parameters, data.calibrations, names, size=(10, 0.3 + 2.0 * rows)
        )
    series = _conditions(data.sessions)
    if series:
        rows = -(-len(series) // 3)
        out["conditions.png"] = report_plots.png(
            _plot_conditions, series, size=(10, 0.5 + 2.0 * rows)
        )
    return out


def _when(calibration: dict) -> Any:
    """When a calibration's session was measured (else when it was made)."""
    return calibration.get("time") or calibration["created"]


def html(data: Timeline, alarms: Sequence[Alarm], limits: Limits, notes: Sequence[str] = ()) -> str:
    """The page as text; ``notes``: what the calibrations were not compared on."""
    pictures = images(data, limits)
    name = data.robot.get("name", "")
    title = f"Calibration history of {name}"
    facts = [
        ("robot", name),
        ("model", data.robot.get("model") or "not recorded"),
        ("serial", data.robot.get("serial") or "not recorded"),
        ("description", data.robot.get("description") or ""),
        ("sessions", len(data.sessions)),
        ("calibrations", len(data.calibrations)),
        ("ISO 9283 tests", len(data.verifications)),
        ("checks", len(data.checks)),
        ("ISO 9283 path tests", len(data.path_verifications)),
        ("circle checks", len(data.circle_checks)),
    ]
    for t in data.trackers:
        cert = t["certificate_date"]
        facts.append(
            ("tracker " + t["name"], f"certificate {cert}" if cert else "no certificate date")
        )
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{_ESC(title)}</title><style>{report_page.STYLE}{_ALARM_STYLE}</style></head><body>",
        f"<h1>{_ESC(title)}</h1>",
        '<section id="summary"><h2>Summary</h2><table>',
        *(f"<tr><th>{_ESC(k)}</th><td>{_ESC(str(v))}</td></tr>" for k, v in facts),
        "</table></section>",
        '<section id="alarms"><h2>Alarms</h2>',
    ]
    if alarms:
        parts.append(
            "<table><tr><th>time (UTC)</th><th>kind</th><th>records</th><th>what</th></tr>"
        )
        parts += [
            f'<tr class="alarm"><td>{a.time:%Y-%m-%d %H:%M:%S}</td><td>{_ESC(a.kind)}</td>'
            f"<td>{_ESC(', '.join(a.records))}</td>"
            f'<td class="text">{_ESC(a.message)}</td></tr>'
            for a in alarms
        ]
        parts.append("</table>")
    else:
        parts.append('<p class="note">none</p>')
    parts += [f'<p class="note">{_ESC(n)}</p>' for n in notes]
    parts.append("</section>")
    for key, heading, png, note in (
        ("held_out", "Held-out error over time", "held_out.png", "no calibrations"),
        ("iso9283", "ISO 9283 accuracy and repeatability", "iso9283.png", "no ISO 9283 tests"),
        ("parameters", "Parameters over time", "parameters.png", "no identified parameters"),
        ("conditions", "Measuring conditions", "conditions.png", "no conditions recorded"),
    ):
        parts.append(f'<section id="{key}"><h2>{heading}</h2>')
        parts.append(report_page.image(pictures, png, heading, note))
        if key == "parameters" and png in pictures:
            parts.append(
                '<p class="note">Each identified delta with a band of three standard errors '
                "either side; angles in mrad, lengths in mm.</p>"
            )
        if key == "conditions" and png in pictures:
            parts.append(
                '<p class="note">Each session\'s mean over its poses; units in the names '
                "(degC, hPa, %RH, s).</p>"
            )
        parts.append("</section>")
    parts.append('<section id="checks"><h2>Checks</h2>')
    parts.append(_checks_table(data.checks))
    parts.append('</section><section id="circle-checks"><h2>Circle checks</h2>')
    parts.append(_circles_table(data.circle_checks))
    parts.append('</section><section id="path-tests"><h2>ISO 9283 path tests</h2>')
    parts.append(_paths_table(data.path_verifications))
    parts.append('</section><section id="records"><h2>Records</h2>')
    parts.append(_records_table(data))
    parts.append("</section></body></html>")
    return "\n".join(parts) + "\n"


def _checks_table(checks: list) -> str:
    if not checks:
        return '<p class="note">none</p>'
    rows = [
        "<table><tr><th>time (UTC)</th><th>verdict</th><th>measured mm</th>"
        "<th>predicted mm</th><th>explanation</th></tr>"
    ]
    for c in checks:
        why = "; ".join(explanations(c))
        rows.append(
            f"<tr><td>{c['time']:%Y-%m-%d %H:%M:%S}</td><td>{_ESC(c['verdict'])}</td>"
            f"<td>{c['measured_mm']:.4f}</td><td>{c['predicted_mm']:.4f}</td>"
            f'<td class="text">{_ESC(why)}</td></tr>'
        )
    rows.append("</table>")
    return "\n".join(rows)


def _mm(value: Any, sign: str = "") -> str:
    """A figure's cell: 4 decimals, blank when absent (a reflector's orientation)."""
    return "<td></td>" if value is None else f"<td>{value:{sign}.4f}</td>"


def _circles_table(circles: list) -> str:
    """``check --circle`` runs: verdict, radius error, out-of-roundness, marks, offset (mm)."""
    if not circles:
        return '<p class="note">none</p>'
    rows = [
        "<table><tr><th>time (UTC)</th><th>verdict</th><th>radius mm</th><th>speed mm/s</th>"
        "<th>radius error mm</th><th>out-of-roundness mm</th><th>largest reversal mark mm</th>"
        "<th>centre offset mm</th><th>direction gap mm</th><th>beyond its limit</th></tr>"
    ]
    for c in circles:
        beyond = ", ".join(str(k) for k in (c["document"].get("circle") or {}).get("exceeded", []))
        rows.append(
            f"<tr><td>{c['time']:%Y-%m-%d %H:%M:%S}</td><td>{_ESC(c['verdict'])}</td>"
            f"<td>{c['radius_mm']:.1f}</td><td>{c['speed_mm_s']:.1f}</td>"
            + _mm(c["radius_error_mm"], "+")
            + _mm(c["out_of_roundness_mm"])
            + _mm(c["reversal_mm"])
            + _mm(c["centre_offset_mm"])
            + _mm(c["direction_gap_mm"])
            + f'<td class="text">{_ESC(beyond)}</td></tr>'
        )
    rows.append("</table>")
    return "\n".join(rows)


def _paths_table(paths: list) -> str:
    """``verify --path`` runs: AT_P, RT_P (mm), AV, RV (%), FV (mm/s), AT_a..RT_c (deg)."""
    if not paths:
        return '<p class="note">none</p>'
    angles = ("ata_deg", "atb_deg", "atc_deg", "rta_deg", "rtb_deg", "rtc_deg")
    rows = [
        "<table><tr><th>time (UTC)</th><th>path</th><th>commands</th><th>speed mm/s</th>"
        "<th>AT_P mm</th><th>RT_P mm</th><th>AV %</th><th>RV %</th><th>FV mm/s</th>"
        + "".join(f"<th>{k[:2].upper()}_{k[2]} deg</th>" for k in angles)
        + "</tr>"
    ]
    for p in paths:
        state = "compensated" if p["compensated"] else "nominal"
        rows.append(
            f"<tr><td>{p['measured_at']:%Y-%m-%d %H:%M:%S}</td><td>{_ESC(p['shape'])}</td>"
            f"<td>{state}</td><td>{p['speed_mm_s']:.1f}</td>"
            + "".join(_mm(p[k]) for k in ("at_p_mm", "rt_p_mm"))
            + _mm(p["av_pct"], "+")
            + "".join(_mm(p[k]) for k in ("rv_pct", "fv_mm_s", *angles))
            + "</tr>"
        )
    rows.append("</table>")
    return "\n".join(rows)


def _records_table(data: Timeline) -> str:
    rows = [
        "<table><tr><th>time (UTC)</th><th>record</th><th>held-out / measured mm</th>"
        "<th>predicted mm</th><th>AP mm</th><th>RP mm</th><th>verdict</th></tr>"
    ]
    for r in table(data):
        cells = [
            "" if r[k] is None else f"{r[k]:.4f}"
            for k in ("held_out_mm", "predicted_mm", "ap_mm", "rp_mm")
        ]
        rows.append(
            f"<tr><td>{r['time']:%Y-%m-%d %H:%M:%S}</td><td>{_ESC(r['record'])}</td>"
            + "".join(f"<td>{c}</td>" for c in cells)
            + f"<td>{_ESC(r['verdict'] or '')}</td></tr>"
        )
    rows.append("</table>")
    return "\n".join(rows)


def _order(name: str) -> tuple:
    from calibrator.model import parameters

    names = list(parameters.ALL_NAMES)
    return (names.index(name) if name in names else len(names), name)


def _held_out(fig: Any, data: Timeline, limits: Limits) -> None:
    ax = fig.add_subplot()
    cals = [c for c in data.calibrations if c["held_out_rms_mm"] is not None]
    if cals:
        times = [_when(c) for c in cals]
        ax.plot(times, [c["held_out_rms_mm"] for c in cals], "o-", label="held-out (calibration)")
        predicted = [(_when(c), c["predicted_mm"]) for c in cals if c["predicted_mm"] is not None]
        if predicted:
            ax.plot(*zip(*predicted, strict=True), "x--", label="predicted (calibration)")
    if data.checks:
        ax.plot(
            [c["time"] for c in data.checks],
            [c["measured_mm"] for c in data.checks],
            "s",
            label="measured (check)",
        )
        bad = [c for c in data.checks if c["verdict"] != "ok"]
        if bad:
            ax.plot(
                [c["time"] for c in bad],
                [c["measured_mm"] for c in bad],
                "o",
                markersize=12,
                markerfacecolor="none",
                color="#b00",
                label="check not ok",
            )
    limit = limits.held_out_mm
    if limit is None and cals:
        from calibrator.history.alarms import LIMIT_FACTOR

        limit = LIMIT_FACTOR * cals[0]["held_out_rms_mm"]
    if limit is not None:
        ax.axhline(limit, color="#b00", linestyle=":", label=f"limit {limit:.3f} mm")
    ax.set_ylabel("mean position error (mm)")
    ax.set_xlabel("date (UTC)")
    ax.legend(fontsize="small")
    _dates(ax)


def _iso(fig: Any, verifications: list) -> None:
    ax = fig.add_subplot()
    for compensated, label in ((True, "compensated"), (False, "nominal")):
        tests = [v for v in verifications if bool(v["compensated"]) == compensated]
        if tests:
            times = [v["measured_at"] for v in tests]
            ax.plot(times, [v["ap_mm"] for v in tests], "o-", label=f"AP, {label}")
            ax.plot(times, [v["rp_mm"] for v in tests], "s--", label=f"RP, {label}")
    ax.set_ylabel("largest over the test poses (mm)")
    ax.set_xlabel("date (UTC)")
    ax.legend(fontsize="small")
    _dates(ax)


def _parameters(fig: Any, calibrations: list, names: list) -> None:
    cols = 4
    rows = -(-len(names) // cols)
    fig.subplots_adjust(left=0.07, right=0.98, bottom=0.08, top=0.97, hspace=0.9, wspace=0.45)
    for i, name in enumerate(names):
        ax = fig.add_subplot(rows, cols, i + 1)
        scale, unit = (1e3, "mrad") if unit_of(name) == "rad" else (1.0, "mm")
        pts = [
            (_when(c), c["parameters"][name] * scale, c["uncertainties"].get(name, 0.0) * scale)
            for c in calibrations
            if name in c["parameters"]
        ]
        times = [p[0] for p in pts]
        values = [p[1] for p in pts]
        band = [3 * p[2] for p in pts]
        ax.fill_between(
            times, [v - b for v, b in zip(values, band, strict=True)],
            [v + b for v, b in zip(values, band, strict=True)], alpha=0.3,
        )  # fmt: skip
        # Error bars too: calibrations made close together leave the band no width.
        ax.errorbar(times, values, yerr=band, fmt="o-", markersize=3, capsize=2)
        ax.set_title(f"{name} ({unit})", fontsize="small")
        ax.tick_params(labelsize="x-small")
        _dates(ax, ticks=4)


def _conditions(sessions: list) -> dict[str, list]:
    """Numeric conditions of the sessions: ``{key: [(time, value), ...]}`` (nested keys dotted)."""
    series: dict[str, list] = {}

    def walk(prefix: str, value: Any, when: Any) -> None:
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}.{k}" if prefix else str(k), v, when)
        elif isinstance(value, int | float) and not isinstance(value, bool):
            # A column's summary: its mean stands for it.
            if not prefix.endswith((".min", ".max")) and prefix != "poses_reporting":
                series.setdefault(prefix, []).append((when, float(value)))

    for s in sessions:
        walk("", s["conditions"], s["measured_at"])
    return series


def _plot_conditions(fig: Any, series: dict) -> None:
    """One small plot per condition: each has its own unit (in its name: _c, _hpa, _pct, _s)."""
    cols = 3
    rows = -(-len(series) // cols)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.1, top=0.92, hspace=0.9, wspace=0.4)
    for i, (key, points) in enumerate(sorted(series.items())):
        ax = fig.add_subplot(rows, cols, i + 1)
        ax.plot(*zip(*points, strict=True), "o-", markersize=3)
        ax.set_title(key.removesuffix(".mean"), fontsize="small")
        ax.tick_params(labelsize="x-small")
        _dates(ax, ticks=4)


def _dates(ax: Any, ticks: int = 6) -> None:
    """Dates on the x axis, few and short (matplotlib's concise format)."""
    from matplotlib import dates

    low, high = ax.dataLim.intervalx
    if high - low < 3:  # days: records made together are shown over three days
        middle = (low + high) / 2
        ax.set_xlim(middle - 1.5, middle + 1.5)
    locator = dates.AutoDateLocator(minticks=2, maxticks=ticks)
    ax.xaxis.set_major_locator(locator)
    ax.xaxis.set_major_formatter(dates.ConciseDateFormatter(locator))
