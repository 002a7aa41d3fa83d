"""Acceptance check M3: the history page renders in headless Chromium with its plots and alarms."""

import shutil
import subprocess
from datetime import datetime, timedelta

import numpy as np
import pytest
from cli_kit import cli
from history_kit import check_doc

from calibrator.history import open_history

ROBOT = "sim:er10l-c10:seed=3"


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


@pytest.fixture
def page(tmp_path, measured):
    history = tmp_path / "h.sqlite"
    assert cli("history", "import", measured, "--history", history, cwd=tmp_path).code == 0
    with open_history(history) as h:
        h.record_check(check_doc(robot=ROBOT, day=400, measured=0.04))
        h.record_check(
            check_doc(robot=ROBOT, day=401, verdict="recalibrate", measured=0.4,
                      explanation=["joint 2 zero moved 0.41 ± 0.03 mrad: re-master J2"])
        )  # fmt: skip
    result = cli("history", ROBOT, "--history", history, "--html", "page", cwd=tmp_path)
    assert result.code == 0, result.stderr
    return tmp_path / "page" / "index.html"


def test_page_holds_plots_alarms_and_units(page):
    text = page.read_text()
    for alt in (
        "Held-out error over time",
        "ISO 9283 accuracy and repeatability",
        "Parameters over time",
    ):
        assert f'alt="{alt}"' in text
    # The check that said recalibrate; the held-out error of the third calibration
    # (noise 0.06 mm) above twice the first's (noise 0.02 mm).
    assert text.count('<tr class="alarm">') == 2
    assert "held-out error 0.063 mm is above its limit 0.049 mm" in text
    assert "recalibrate: measured 0.400 mm against 0.050 mm predicted" in text
    assert "angles in mrad, lengths in mm" in text
    assert "no conditions recorded" in text  # simulated sessions record none


@pytest.mark.skipif(_chromium() is None, reason="no chromium binary")
def test_page_renders_in_headless_chromium(page, tmp_path):
    from matplotlib import image

    shot = tmp_path / "shot.png"
    subprocess.run(
        [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         "--window-size=1200,4000", f"--screenshot={shot}", page.as_uri()],
        check=True, capture_output=True, timeout=120,
    )  # fmt: skip
    pixels = (image.imread(shot)[..., :3] * 255).round().astype(int)

    def count(rgb, tol=40):
        return int((np.abs(pixels - np.array(rgb)).sum(axis=-1) < tol).sum())

    # The alarm rows' red text (#b00), and the plots' lines, points and the
    # parameters' uncertainty bars (matplotlib's blue).
    assert count((0xBB, 0, 0)) > 200
    assert count((0x1F, 0x77, 0xB4)) > 2000


def test_conditions_plotted_are_the_numbers_of_each_session():
    from calibrator.history import page

    sessions = [
        {"measured_at": datetime(2026, 1, 1) + timedelta(days=30 * m), "conditions": {
            "air_temperature_c": {"min": 20.0 + m, "mean": 20.5 + m, "max": 21.0 + m},
            "tracker_warmed_up": True, "poses_reporting": 30}}
        for m in range(2)
    ] + [{"measured_at": datetime(2026, 3, 2), "conditions": {}}]  # fmt: skip
    assert page._conditions(sessions) == {
        "air_temperature_c.mean": [(datetime(2026, 1, 1), 20.5), (datetime(2026, 1, 31), 21.5)]
    }
