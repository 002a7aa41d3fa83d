"""What the history page draws and writes, read back from the figures and the HTML.

Each plot is drawn on a real matplotlib figure (as the page draws it) and its
artists are read: which series, at which times and values, with which
labels, and the date axis's span; the HTML's summary, tables and notes are
read as text. Found by mutation testing (issue 44): the page test reads
three headings and two alarms, not what the plots and tables hold.
"""

from __future__ import annotations

import re
from datetime import datetime, timedelta

import numpy as np
import pytest
from matplotlib import dates as mdates

from calibrator.history import alarms, page
from calibrator.history.alarms import Limits
from calibrator.history.timeline import Timeline

T0 = datetime(2026, 3, 1, 8, 0, 0)


def _day(n: float) -> datetime:
    return T0 + timedelta(days=n)


def _calibration(number, day, held_out, predicted, params, se):
    return {
        "id": number,
        "time": _day(day),
        "created": _day(day + 1),
        "held_out_rms_mm": held_out,
        "predicted_mm": predicted,
        "parameters": params,
        "uncertainties": se,
        "file": f"cal{number}.json",
    }


def _check(number, day, verdict, measured, explanation=()):
    return {
        "id": number,
        "time": _day(day),
        "verdict": verdict,
        "measured_mm": measured,
        "predicted_mm": 0.05,
        "explanation": list(explanation),
        "document": {},
    }


def _verification(number, day, compensated, ap, rp):
    return {
        "id": number,
        "measured_at": _day(day),
        "compensated": compensated,
        "ap_mm": ap,
        "rp_mm": rp,
        "file": f"v{number}.json",
    }


def _timeline(**more) -> Timeline:
    calibrations = [
        _calibration(1, 0, 0.05, 0.04, {"theta2": 1e-4, "a3": 0.2}, {"theta2": 1e-5, "a3": 0.01}),
        _calibration(2, 30, 0.06, None, {"theta2": 3e-4, "a3": 0.3}, {"theta2": 2e-5}),
    ]
    fields = {
        "robot": {"name": "arm-1", "model": "ur10e", "serial": None, "description": None},
        "calibrations": calibrations,
        "checks": [_check(7, 40, "ok", 0.05), _check(8, 50, "recalibrate", 0.3, ["J2 moved"])],
        "verifications": [
            _verification(3, 10, True, 0.11, 0.021),
            _verification(4, 20, False, 0.51, 0.022),
        ],
    }
    return Timeline(**{**fields, **more})


def _figure(draw, *args, size=(7, 4)):
    """The figure ``draw(fig, *args)`` makes, as :func:`calibrator.report.plots.png` sets it up."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, dpi=100)
    FigureCanvasAgg(fig)
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.12, top=0.9, wspace=0.45)
    draw(fig, *args)
    return fig


def _lines(ax) -> dict:
    return {line.get_label(): line for line in ax.get_lines()}


def _x_dates(line) -> list[datetime]:
    return [mdates.num2date(x).replace(tzinfo=None) for x in mdates.date2num(line.get_xdata())]


def _close(a: datetime, b: datetime) -> bool:
    return abs((a - b).total_seconds()) < 1e-3


# -- plots --------------------------------------------------------------------------------


def test_the_held_out_plot_marks_the_checks_not_ok_and_draws_the_limit():
    data = _timeline()
    (ax,) = _figure(page._held_out, data, Limits()).axes
    lines = _lines(ax)
    assert list(lines) == [
        "held-out (calibration)",
        "predicted (calibration)",
        "measured (check)",
        "check not ok",
        "limit 0.100 mm",  # twice the first calibration's held-out error
    ]
    held = lines["held-out (calibration)"]
    assert [d.date() for d in _x_dates(held)] == [_day(0).date(), _day(30).date()]
    # A calibration whose session time is unknown is drawn when it was made.
    older = _timeline(calibrations=[{**data.calibrations[0], "time": None}], checks=[])
    (ax_older,) = _figure(page._held_out, older, Limits()).axes
    assert _close(_x_dates(ax_older.get_lines()[0])[0], _day(1))
    assert list(held.get_ydata()) == [0.05, 0.06]
    # Only the calibration with a prediction has a point on the predicted line,
    # drawn dashed with crosses (the held-out error: solid with circles).
    predicted = lines["predicted (calibration)"]
    assert list(predicted.get_ydata()) == [0.04]
    assert (predicted.get_marker(), predicted.get_linestyle()) == ("x", "--")
    assert (held.get_marker(), held.get_linestyle()) == ("o", "-")
    assert list(lines["measured (check)"].get_ydata()) == [0.05, 0.3]
    bad = lines["check not ok"]
    assert list(bad.get_ydata()) == [0.3] and _close(_x_dates(bad)[0], _day(50))
    assert list(lines["limit 0.100 mm"].get_ydata()) == [0.1, 0.1]
    # A limit given is the one drawn.
    (ax,) = _figure(page._held_out, data, Limits(held_out_mm=0.25)).axes
    assert "limit 0.250 mm" in _lines(ax)


def test_the_held_out_plot_of_checks_all_ok_has_no_marks():
    data = _timeline(checks=[_check(7, 40, "ok", 0.05)])
    (ax,) = _figure(page._held_out, data, Limits()).axes
    assert "check not ok" not in _lines(ax)


def test_the_iso_plot_draws_ap_and_rp_of_each_series_at_its_times():
    data = _timeline()
    (ax,) = _figure(page._iso, data.verifications).axes
    lines = _lines(ax)
    assert list(lines) == ["AP, compensated", "RP, compensated", "AP, nominal", "RP, nominal"]
    assert list(lines["AP, compensated"].get_ydata()) == [0.11]
    assert list(lines["RP, compensated"].get_ydata()) == [0.021]
    assert list(lines["AP, nominal"].get_ydata()) == [0.51]
    assert list(lines["RP, nominal"].get_ydata()) == [0.022]
    assert _close(_x_dates(lines["RP, nominal"])[0], _day(20))
    # AP solid with circles, RP dashed with squares.
    assert (lines["AP, nominal"].get_marker(), lines["AP, nominal"].get_linestyle()) == ("o", "-")
    assert (lines["RP, nominal"].get_marker(), lines["RP, nominal"].get_linestyle()) == ("s", "--")


def test_the_parameter_plots_show_each_delta_with_a_band_of_three_standard_errors():
    data = _timeline()
    names = ["theta2", "a3"]
    fig = _figure(page._parameters, data.calibrations, names, size=(10, 2.3))
    theta2, a3 = fig.axes[0], fig.axes[-1]
    assert theta2.get_title() == "theta2 (mrad)" and a3.get_title() == "a3 (mm)"
    # The error bars' line: the values in display units, at the calibrations' times.
    line = theta2.get_lines()[0]  # then the caps
    assert np.allclose(line.get_ydata(), [0.1, 0.3])
    assert (line.get_marker(), line.get_markersize()) == ("o", 3)
    assert [d.date() for d in _x_dates(line)] == [_day(0).date(), _day(30).date()]
    # The band: value +- 3 standard errors, over the same times.
    (band,) = theta2.collections[:1]
    vertices = band.get_paths()[0].vertices
    assert np.isclose(vertices[:, 0].min(), mdates.date2num(_day(0)))
    assert np.isclose(vertices[:, 0].max(), mdates.date2num(_day(30)))
    assert np.isclose(vertices[:, 1].min(), 0.1 - 3 * 0.01)
    assert np.isclose(vertices[:, 1].max(), 0.3 + 3 * 0.02)
    # a3 of the second calibration has no standard error: no band there.
    vertices = a3.collections[0].get_paths()[0].vertices
    assert np.isclose(vertices[:, 1].max(), 0.3)


def test_the_parameter_and_condition_grids_keep_their_fixed_margins():
    data = _timeline()
    fig = _figure(page._parameters, data.calibrations, ["theta2", "a3"], size=(10, 2.3))
    assert (fig.subplotpars.left, fig.subplotpars.bottom) == (0.07, 0.08)
    series = {"air_temperature_c.mean": [(_day(0), 20.5), (_day(40), 21.5)]}
    fig = _figure(page._plot_conditions, series, size=(10, 2.5))
    pars = fig.subplotpars
    assert (pars.left, pars.right, pars.bottom, pars.top) == (0.08, 0.98, 0.1, 0.92)


def test_the_condition_plots_are_named_without_their_mean_and_hold_the_sessions_values():
    series = {
        "air_temperature_c.mean": [(_day(0), 20.5), (_day(40), 21.5)],
        "pressure_hpa.mean": [(_day(0), 1010.0), (_day(40), 1012.0)],
    }
    fig = _figure(page._plot_conditions, series, size=(10, 2.5))
    assert [ax.get_title() for ax in fig.axes] == ["air_temperature_c", "pressure_hpa"]
    (line,) = fig.axes[1].get_lines()
    assert list(line.get_ydata()) == [1010.0, 1012.0]
    # At most four date ticks under each small plot.
    assert set(fig.axes[0].xaxis.get_major_locator().maxticks.values()) == {4}


def test_records_made_together_are_shown_over_three_days_around_them():
    fig = _figure(page._iso, [_verification(3, 10, True, 0.11, 0.021)])
    low, high = fig.axes[0].get_xlim()
    middle = mdates.date2num(_day(10))
    assert np.isclose(low, middle - 1.5) and np.isclose(high, middle + 1.5)
    # Spread over more than three days: the axis is matplotlib's own.
    data = _timeline()
    fig = _figure(page._iso, data.verifications)
    low, high = fig.axes[0].get_xlim()
    assert low <= mdates.date2num(_day(10)) and high >= mdates.date2num(_day(20))
    assert high - low < 20


def test_the_page_draws_every_plot_it_has_data_for():
    sessions = [
        {"measured_at": _day(0), "conditions": {"air_temperature_c": {"mean": 20.5}}},
        {"measured_at": _day(30), "conditions": {"air_temperature_c": {"mean": 21.0}}},
    ]
    pictures = page.images(_timeline(sessions=sessions), Limits())
    assert sorted(pictures) == ["conditions.png", "held_out.png", "iso9283.png", "parameters.png"]
    assert all(p.startswith(b"\x89PNG") for p in pictures.values())
    empty = Timeline(robot={"name": "arm-2"})
    assert page.images(empty, Limits()) == {}


# -- HTML ---------------------------------------------------------------------------------


def _section(text: str, key: str) -> str:
    start = text.index(f'<section id="{key}">')
    return text[start : text.index("</section>", start) + len("</section>")]


def test_the_summary_names_each_tracker_with_its_certificate_date():
    from datetime import date

    trackers = [
        {"name": "leica:AT960:7", "certificate_date": date(2026, 2, 1)},
        {"name": "api:radian:9", "certificate_date": None},
    ]
    text = page.html(_timeline(trackers=trackers, checks=[], verifications=[]), [], Limits())
    summary = _section(text, "summary")
    assert "<tr><th>tracker leica:AT960:7</th><td>certificate 2026-02-01</td></tr>" in summary
    assert "<tr><th>tracker api:radian:9</th><td>no certificate date</td></tr>" in summary
    assert "<tr><th>model</th><td>ur10e</td></tr>" in summary
    assert "<tr><th>serial</th><td>not recorded</td></tr>" in summary
    assert summary.endswith("</td></tr>\n</table></section>")
    assert '</table></section>\n<section id="alarms">' in text


def test_the_checks_and_records_tables_hold_one_row_each_and_are_closed():
    data = _timeline()
    found = alarms.alarms(data.calibrations, data.verifications, data.checks)
    text = page.html(data, found, Limits())
    checks = _section(text, "checks")
    assert checks == "\n".join(
        [
            '<section id="checks"><h2>Checks</h2>',
            "<table><tr><th>time (UTC)</th><th>verdict</th><th>measured mm</th>"
            "<th>predicted mm</th><th>explanation</th></tr>",
            "<tr><td>2026-04-10 08:00:00</td><td>ok</td><td>0.0500</td><td>0.0500</td>"
            '<td class="text"></td></tr>',
            "<tr><td>2026-04-20 08:00:00</td><td>recalibrate</td><td>0.3000</td><td>0.0500</td>"
            '<td class="text">J2 moved</td></tr>',
            "</table>",
            "</section>",
        ]
    )
    records = _section(text, "records")
    assert records.count("<tr><td>") == 6  # 2 calibrations, 2 tests, 2 checks
    assert records.endswith("</table>\n</section>")
    assert "<tr><td>2026-03-11 08:00:00</td><td>iso9283 compensated</td>" in records
    # Every table opened is closed.
    assert text.count("<table>") == text.count("</table>")


def test_each_plot_section_has_its_heading_and_its_note():
    sessions = [
        {"id": 1, "measured_at": _day(0), "file": "s.parquet",
         "conditions": {"air_temperature_c": {"mean": 20.5}}}
    ]  # fmt: skip
    text = page.html(_timeline(sessions=sessions), [], Limits())
    headings = re.findall(r'<section id="(\w+)"><h2>([^<]*)</h2>', text)
    assert headings == [
        ("summary", "Summary"),
        ("alarms", "Alarms"),
        ("held_out", "Held-out error over time"),
        ("iso9283", "ISO 9283 accuracy and repeatability"),
        ("parameters", "Parameters over time"),
        ("conditions", "Measuring conditions"),
        ("checks", "Checks"),
        ("records", "Records"),
    ]
    assert "angles in mrad, lengths in mm" in _section(text, "parameters")
    assert "units in the names" in _section(text, "conditions")
    # Nothing stray between the sections.
    bare_text = re.sub(r'src="data:image/png;base64,[^"]*"', "", text)
    assert set(re.findall(r"</section>(.*?)<section", bare_text, re.S)) <= {"", "\n"}
    assert bare_text.endswith("</section></body></html>\n")
    # Without parameters or conditions: the notes saying so, not the plots' captions.
    bare = page.html(_timeline(calibrations=[]), [], Limits())
    assert '<p class="note">no identified parameters</p>' in _section(bare, "parameters")
    assert "angles in mrad" not in bare and "units in the names" not in bare
    assert '<p class="note">no conditions recorded</p>' in _section(bare, "conditions")


def test_the_alarms_section_lists_each_alarm_in_a_row():
    data = _timeline()
    found = alarms.alarms(data.calibrations, data.verifications, data.checks)
    text = page.html(data, found, Limits(), notes=["tool not compared: no tool"])
    section = _section(text, "alarms")
    assert section.count('<tr class="alarm">') == len(found) >= 2
    row = next(r for r in section.split("\n") if "check 8" in r)
    assert row.startswith('<tr class="alarm"><td>2026-04-20 08:00:00</td><td>check</td>')
    assert '<p class="note">tool not compared: no tool</p>' in section
    quiet = _section(page.html(data, [], Limits()), "alarms")
    assert '<p class="note">none</p>' in quiet


@pytest.mark.parametrize("name, rank", [("theta1", 0), ("zzz_unknown", None)])
def test_parameters_are_plotted_in_the_models_order(name, rank):
    from calibrator.model import parameters

    order = page._order(name)
    if rank is None:
        assert order == (len(parameters.ALL_NAMES), name)
    else:
        assert order == (list(parameters.ALL_NAMES).index(name), name)
