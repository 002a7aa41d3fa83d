"""The report's ISO 9283 path section: verify --path results tabled and drawn."""

import json
from pathlib import Path

import pytest

from calibrator.errors import CalibrationError
from calibrator.report import path_section as ps
from calibrator.report import verify_section as vs


def path_doc(shape, at_p, compensated, corners=False):
    """A verify --path result whose per-point accuracy rises to ``at_p`` mid-path."""
    s = [float(k) for k in range(0, 100, 10)]
    at = [at_p * (1 - abs(k - 50) / 50) for k in s]
    path = {
        "shape": shape, "speed_mm_s": 135.2, "speed_pct": 50.0, "rated_speed_mm_s": 270.4,
        "cycles": 2, "compensated": compensated, "AT_P_mm": max(at), "RT_P_mm": 0.02,
        "AV_pct": 0.05, "RV_pct": 0.003, "FV_mm_s": 4.5,
        "points": {"s_mm": s, "AT_mm": at, "RT_mm": [0.02] * len(s)},
    }  # fmt: skip
    if corners:
        path |= {"CR_mm": [0.5, 0.37, 0.97], "CO_mm": [0.0, 0.47, 0.2]}
    return {"format": "calibrator.verify", "test": "path", "path": path}


def write(folder, name, doc):
    (folder / name).write_text(json.dumps(doc))
    return folder / name


def test_path_results_load_beside_pose_results_and_get_their_own_section(tmp_path):
    files = [
        write(tmp_path, "before.json", path_doc("rectangle", 1.0, False, corners=True)),
        write(tmp_path, "after.json", path_doc("rectangle", 0.01, True, corners=True)),
    ]
    runs = vs.load(files)
    html, images = vs.add("<html><body></body></html>", runs)
    assert set(images) == {ps.PATH_PNG} and images[ps.PATH_PNG][:4] == b"\x89PNG"
    assert 'id="verify-path"' in html and 'id="verify"' not in html  # no pose test given
    table = html[html.index("<table>") : html.index("</table>")]
    rows = table.split("<tr>")[2:]
    assert len(rows) == 2
    assert (
        "<td>1: before (nominal): before.json</td><td>rectangle</td><td>135.2</td><td>50</td>"
        in rows[0]
    )
    assert "<td>1.0000</td>" in rows[0] and "<td>0.0100</td>" in rows[1]  # AT_P
    assert "<td>0.9700</td><td>0.4700</td>" in rows[0]  # the worst corner's CR and CO


def test_the_plot_draws_each_runs_accuracy_along_the_path():
    runs = [vs.VerifyRun(Path(f"{k}.json"), path_doc("line", a, k == "b"), None)
            for k, a in (("a", 1.0), ("b", 0.01))]  # fmt: skip
    ax = ps.path_figure(runs).axes[0]
    lines = ax.get_lines()
    assert [max(line.get_ydata()) for line in lines] == pytest.approx([1.0, 0.01])
    assert list(lines[0].get_xdata()) == runs[0].doc["path"]["points"]["s_mm"]


def test_the_bad_path_result_is_named_by_load(tmp_path):
    doc = path_doc("line", 1.0, False)
    del doc["path"]["points"]
    with pytest.raises(CalibrationError, match="bad.json: a path test without its figures"):
        vs.load([write(tmp_path, "bad.json", doc)])
