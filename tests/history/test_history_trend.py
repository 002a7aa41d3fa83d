"""A year of monthly calibrations built in seconds from dated simulated sessions: the trend alarm.

``simulate --measured-at`` dates each month's session; ``identify --history``
records it, filed under the month it was measured (not the day the test
ran). The arm's tracker gets noisier from month 7 on, so the held-out error
rises; the trend alarm fires at the months where the straight line through
the last four held-out errors reaches the limit within 90 days, and nowhere
else (that line is computed here with numpy, apart from the history's code).
"""

import json
from datetime import datetime

import numpy as np
from cli_kit import cli

ROBOT = "sim:ur10e:seed=7"
#: The held-out error the lab accepts (mm): about twice month 1's.
LIMIT_MM = 0.05


def _noise(month):
    """The tracker's noise (mm): steady for six months, then worsening."""
    return 0.02 if month <= 6 else 0.02 + 0.006 * (month - 6)


def test_a_dated_year_fires_the_trend_alarm_where_the_line_reaches_the_limit(tmp_path):
    history = tmp_path / "year.sqlite"
    for month in range(1, 13):
        name = f"m{month:02d}"
        done = cli(
            "simulate", "--model", "ur10e", "--seed", 7, "--frame", "tracker", "--no-orientation",
            "--poses", 40, "--noise-mm", _noise(month), "--measured-at",
            f"2026-{month:02d}-01T08:00:00Z", "-o", f"{name}.parquet", cwd=tmp_path,
        )  # fmt: skip
        assert done.code == 0, done.stderr
        done = cli(
            "identify", f"{name}.parquet", "-o", f"{name}.json", "-q", "--history", history,
            cwd=tmp_path,
        )  # fmt: skip
        assert done.code == 0, done.stderr
    shown = cli(
        "history", ROBOT, "--history", history, "--csv", "table.csv", "--held-out-limit-mm",
        LIMIT_MM, cwd=tmp_path,
    )  # fmt: skip
    assert shown.code == 0, shown.stderr
    rows = [
        line.split(",")
        for line in (tmp_path / "table.csv").read_text().splitlines()[1:]
        if ",calibration," in line
    ]
    # Filed under the month measured, not today.
    times = [datetime.fromisoformat(r[0]) for r in rows]
    assert times == [datetime(2026, m, 1, 8) for m in range(1, 13)]
    held_out = [float(r[3]) for r in rows]
    limit = LIMIT_MM
    # The line through each month and the three before it, as the history looked that day.
    expected = []
    for i in range(3, 12):
        days = np.array([(t - times[i - 3]).total_seconds() / 86400 for t in times[i - 3 : i + 1]])
        slope, intercept = np.polyfit(days, held_out[i - 3 : i + 1], 1)
        now = intercept + slope * days[-1]
        if held_out[i] <= limit and slope > 0 and (limit - now) / slope <= 90:
            expected.append(times[i])
    found = cli(
        "history", "alarms", ROBOT, "--history", history, "--json", "-", "--held-out-limit-mm",
        LIMIT_MM, cwd=tmp_path,
    )  # fmt: skip
    alarms = json.loads(found.stdout)["alarms"]
    trend = [
        datetime.fromisoformat(a["time"].removesuffix("Z")) for a in alarms if a["kind"] == "trend"
    ]
    assert trend == expected
    # It fires, not before the noise worsened, and not once the limit is crossed
    # (there the limit alarm speaks).
    assert trend == [datetime(2026, 9, 1, 8), datetime(2026, 10, 1, 8)]
    limits = [datetime.fromisoformat(a["time"].removesuffix("Z")) for a in alarms
              if a["kind"] == "limit"]  # fmt: skip
    assert limits == [datetime(2026, 11, 1, 8), datetime(2026, 12, 1, 8)]
    assert {a["kind"] for a in alarms} == {"trend", "limit"}  # the arm itself never moved
