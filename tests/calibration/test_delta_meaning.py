"""A base or tool delta is one number: the same in the report, calibration.json and the CSV."""

import csv
import json
import re

import numpy as np
from cli_process_kit import run_cli  # the CLI as a user runs it: a real process

from calibrator import calibration
from calibrator.model import frames


def test_base_and_tool_deltas_agree_in_report_json_and_csv(tmp_path):
    # A tracker-frame session: the base is metres away and turned, the tool unknown.
    sim = run_cli(
        "simulate", "-o", "s.parquet", "--poses", "30", "--frame", "tracker",
        "--tool-offset-mm", "3", cwd=tmp_path,
    )  # fmt: skip
    assert sim.returncode == 0, sim.stderr
    ident = run_cli(
        "identify", "s.parquet", "-o", "c.json", "--method", "lm", "--report", "rep",
        cwd=tmp_path,
    )  # fmt: skip
    assert ident.returncode == 0, ident.stderr
    exported = run_cli("export-params", "c.json", "-o", "c.csv", cwd=tmp_path)
    assert exported.returncode == 0, exported.stderr
    doc = json.loads((tmp_path / "c.json").read_text())
    records = {r["name"]: r for r in doc["parameters"]}
    with open(tmp_path / "c.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    field = {"tx": "x_mm", "ty": "y_mm", "tz": "z_mm", "rx": "rx_rad", "ry": "ry_rad"}
    field |= {"rz": "rz_rad", "x": "x_mm", "y": "y_mm", "z": "z_mm"}
    page = (tmp_path / "rep" / "index.html").read_text()
    frame_names = [n for n in doc["free_parameters"] if n.startswith(("base_", "tool_"))]
    assert {"base_tx", "base_rz", "tool_x"} <= set(frame_names)
    for name in frame_names:
        element = "base2tracker" if name.startswith("base_") else "flange2tool"
        kind = field[name.split("_")[1]]
        row = next(r for r in rows if r["element"] == element and r["parameter"] == kind)
        delta = doc["deltas"][name]
        assert float(row["delta"]) == delta == records[name]["delta"], name
        scale = np.degrees(1.0) if kind.endswith("_rad") else 1.0  # the report: mm and deg
        shown = re.search(rf"<tr><td>{name}</td>(?:<td>[^<]*</td>){{3}}<td>([^<]*)</td>", page)
        assert shown, name
        decimals = len(shown.group(1).split(".")[1])  # as the column shows them
        assert float(shown.group(1)) == round(delta * scale, decimals), name
    # The base is turned against the tracker: its translation delta is in the
    # first-guess base frame, not a difference of tracker coordinates.
    cal = calibration.load(tmp_path / "c.json")
    move = frames.invert(cal.base0) @ cal.base2tracker
    np.testing.assert_allclose(
        [doc["deltas"][n] for n in ("base_tx", "base_ty", "base_tz")], move[:3, 3], atol=1e-12
    )
    tracker_diff = records["base_tx"]["identified"] - records["base_tx"]["nominal"]
    assert abs(tracker_diff - doc["deltas"]["base_tx"]) > 1e-3
