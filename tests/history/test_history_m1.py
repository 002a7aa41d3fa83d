"""Acceptance check M1 through the history: the alarms agree with the monthly checks.

The arm is calibrated in month 0 (measure, identify --history); months 1, 7
and 8 are checked with ``check --history`` on the simulated cell, its world
file adding slow wear each month and, in month 8, a crash that shifts joint
2's zero. The history then raises no alarm for months 1 and 7 and one for
month 8, naming joint 2. (tests/check/test_m1_monthly.py checks all twelve
months of the check itself.)
"""

import json

from cli_kit import cli

from calibrator.history import alarms, open_history
from calibrator.history.timeline import load

CRASH_RAD = 4e-4


def _world(folder, month):
    crash = CRASH_RAD if month >= 8 else 0.0
    path = folder / f"month{month:02d}.yaml"
    path.write_text(
        "world: 1\nmodel: ur10e\nseed: 11\nrepeatability: true\narm:\n"
        f"  deltas: {{a2: {2e-4 * month:.6f}, a3: {2e-4 * month:.6f}}}\n"
        f"joint_zero_shifts_rad: [0, {crash:.6f}, {5e-7 * month:.9f}, 0, 0, 0]\n"
    )
    return path


def test_monthly_checks_and_the_history_alarms_agree(tmp_path):
    history = tmp_path / "h.sqlite"
    done = cli(
        "measure", "--model", "ur10e", "--world", _world(tmp_path, 0), "--seed", "1",
        "--poses", "30", "-o", "cal.parquet", "-q", cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stderr
    done = cli(
        "identify", "cal.parquet", "-o", "cal.json", "-q", "--history", history, cwd=tmp_path
    )
    assert done.code == 0, done.stderr
    verdicts = {}
    for month in (1, 7, 8):
        out = tmp_path / f"check{month:02d}.json"
        cli(
            "check", "--model", "ur10e", "--calibration", "cal.json", "--world",
            _world(tmp_path, month), "--seed", str(100 + month), "-o", out, "-q",
            "--history", history, cwd=tmp_path,
        )  # fmt: skip
        verdicts[month] = json.loads(out.read_text())
    robot = verdicts[1]["robot"]
    with open_history(history) as store:
        data = load(store, robot)
    assert len(data.calibrations) == 1 and len(data.checks) == 3
    found = alarms.alarms(data.calibrations, data.verifications, data.checks)
    month_of = {c["time"]: m for c, m in zip(data.checks, (1, 7, 8), strict=True)}
    assert [(month_of[a.time], a.kind) for a in found] == [(8, "check")]
    assert verdicts[8]["verdict"] in ("drifted", "recalibrate")
    assert f"{verdicts[8]['verdict']}: measured" in found[0].message
    assert "joint 2 zero moved +0.4" in found[0].message
    # A history imported from the files says the same (the checks' poses beside
    # their JSON are not sessions).
    imported = cli("history", "import", tmp_path, "--history", "again.sqlite", cwd=tmp_path)
    assert "1 sessions, 1 calibrations, 0 verifications, 3 checks" in imported.stdout
    with open_history(tmp_path / "again.sqlite") as store:
        again = load(store, robot)
    assert [c["document"] for c in again.checks] == [c["document"] for c in data.checks]
    # The command line says the same.
    shown = cli("history", robot, "--history", history, cwd=tmp_path)
    (line,) = [s for s in shown.stdout.splitlines() if s.startswith("ALARM")]
    assert "check:" in line and "joint 2 zero" in line
