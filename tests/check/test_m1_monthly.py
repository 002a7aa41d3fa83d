"""Acceptance check M1: a simulated arm checked monthly for a year, slow wear, a crash in month 8.

The arm is calibrated (measure, identify) in month 0; each month its world
file (``--world``) adds a little wear (link lengths growing, joint 3's zero
creeping) and from month 8 on joint 2's zero is shifted by a crash. Every
check runs end to end on the simulated cell (a typical arm's repeatability,
the tracker's noise): no alarm in months 1-7; month 8 and later are flagged,
naming joint 2.
"""

import json

import pytest
from cli_kit import cli

CRASH_RAD = 4e-4


def world(folder, month):
    """The world file of ``month``: wear grows linearly, the crash comes in month 8."""
    crash = CRASH_RAD if month >= 8 else 0.0
    text = (
        "world: 1\n"
        "model: ur10e\n"
        "seed: 11\n"
        "repeatability: true\n"
        "arm:\n"
        f"  deltas: {{a2: {2e-4 * month:.6f}, a3: {2e-4 * month:.6f}, d4: {-1e-4 * month:.6f}}}\n"
        f"joint_zero_shifts_rad: [0, {crash:.6f}, {5e-7 * month:.9f}, 0, 0, 0]\n"
    )
    path = folder / f"month{month:02d}.yaml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("m1")
    measured = cli(
        "measure", "--model", "ur10e", "--world", world(folder, 0), "--seed", "1",
        "--poses", "30", "-o", "cal.parquet", "-q", cwd=folder,
    )  # fmt: skip
    assert measured.code == 0, measured.stderr
    identified = cli("identify", "cal.parquet", "-o", "cal.json", cwd=folder)
    assert identified.code == 0, identified.stderr
    return folder


def test_a_year_of_monthly_checks_flags_the_crash_and_nothing_before(calibrated):
    folder = calibrated
    verdicts = {}
    for month in range(1, 13):
        out = f"check{month:02d}.json"
        result = cli(
            "check", "--model", "ur10e", "--calibration", "cal.json",
            "--world", world(folder, month), "--seed", str(100 + month), "-o", out, "-q",
            cwd=folder,
        )  # fmt: skip
        doc = json.loads((folder / out).read_text())
        assert result.code == {"ok": 0, "drifted": 3, "recalibrate": 4}[doc["verdict"]]
        verdicts[month] = doc
    for month in range(1, 8):
        assert verdicts[month]["verdict"] == "ok", (month, verdicts[month]["p_value"])
        assert verdicts[month]["explanation"] == []
    for month in range(8, 13):
        doc = verdicts[month]
        assert doc["verdict"] == "recalibrate", month
        first = doc["explanation"][0]
        assert first["causes"][0] == "joint 2 zero", (month, doc["explanation_text"])
        change = first["parameters"][0]
        assert change["name"] == "theta2"
        assert abs(change["change"] - CRASH_RAD) < 5 * change["standard_error"] + 2e-5
        assert doc["explanation_text"][0].startswith("joint 2 zero moved +0.4")
