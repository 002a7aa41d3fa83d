"""The report's ISO 9283 section: a table that fits the page, clouds that show their spread."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from calibrator.report import verify_section as vs

KEYS = ("AP_mm", "APx_mm", "APy_mm", "APz_mm", "RP_mm")


def run(name, offset_mm, spread_mm, compensated, seed):
    """A verify result: 10 cycles at each of 5 test poses, ``offset`` off, ``spread`` wide."""
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(1, 6):
        cmd = np.array([700.0 + 10 * k, 100.0, 300.0])
        for _ in range(10):
            got = cmd + [0.1 * offset_mm, -offset_mm, 0.0] + rng.normal(0, spread_mm, 3)
            rows.append({"test_pose": k, "x_mm": got[0], "y_mm": got[1], "z_mm": got[2],
                         "cmd_x_mm": cmd[0], "cmd_y_mm": cmd[1], "cmd_z_mm": cmd[2]})  # fmt: skip
    poses = [{"test_pose": k, **{key: offset_mm for key in KEYS}} for k in range(1, 6)]
    doc = {"format": "calibrator.verify", "poses": poses, "compensated": compensated, "cycles": 10}
    return vs.VerifyRun(Path(name), doc, pd.DataFrame(rows))


RUNS = [run("before.json", 2.0, 0.01, False, 1), run("after.json", 0.01, 0.01, True, 2)]


def test_the_table_is_a_row_per_pose_and_run_and_a_column_per_figure():
    html = vs.section_html(RUNS, {})
    table = html[html.index("<table>") : html.index("</table>")]
    rows = table.split("<tr>")[1:]
    assert rows[0].count("<th>") == 2 + len(KEYS)  # test pose, run, the figures
    assert len(rows) == 1 + 5 * len(RUNS)
    assert all(r.count("<td>") == 2 + len(KEYS) for r in rows[1:])
    assert "<td>P1</td><td>1: before (nominal)</td><td>2.0000</td>" in rows[1]
    assert '<div class="wide">' in html  # scrolls rather than overflow if it ever must


def test_clouds_share_one_scale_per_row_and_the_spread_is_not_a_dot():
    fig = vs.clouds_figure(RUNS)
    tops, bottoms = fig.axes[:5], fig.axes[5:10]
    for row in (tops, bottoms):
        assert len({ax.get_xlim() for ax in row}) == 1 and len({ax.get_ylim() for ax in row}) == 1
    reach = tops[0].get_xlim()[1]
    spread = bottoms[0].get_xlim()[1]
    assert reach == pytest.approx(2.0 * 1.15, rel=0.05)  # the 2 mm offset fills the top row
    # The clouds (0.01 mm) fill the bottom row: a panel a few spreads wide, not 2 mm.
    assert 0.02 < spread < 0.06
    assert vs.clouds_png(RUNS)[:4] == b"\x89PNG"
