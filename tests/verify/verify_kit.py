"""Helpers of the verify tests: an independent recomputation of the figures."""

import json
import math

import pandas as pd

COLUMNS = ["test_pose", "cycle", "x_mm", "y_mm", "z_mm", "cmd_x_mm", "cmd_y_mm", "cmd_z_mm"]


def recompute(parquet):
    """AP and RP per test pose from verify.parquet, written out plainly (no project code)."""
    table = pd.read_parquet(parquet)
    out = {}
    for pose, rows in table.groupby("test_pose"):
        pts = rows[["x_mm", "y_mm", "z_mm"]].to_numpy()
        cmd = rows[["cmd_x_mm", "cmd_y_mm", "cmd_z_mm"]].to_numpy()
        assert (cmd == cmd[0]).all()  # one commanded position per test pose
        n = len(pts)
        bary = [sum(p[k] for p in pts) / n for k in range(3)]
        ap = math.sqrt(sum((bary[k] - cmd[0][k]) ** 2 for k in range(3)))
        dist = [math.sqrt(sum((p[k] - bary[k]) ** 2 for k in range(3))) for p in pts]
        lbar = sum(dist) / n
        s = math.sqrt(sum((d - lbar) ** 2 for d in dist) / (n - 1))
        out[int(pose)] = (ap, lbar + 3 * s, [bary[k] - cmd[0][k] for k in range(3)])
    return out


def check_outputs(folder, name, cycles):
    doc = json.loads((folder / f"{name}.json").read_text())
    table = pd.read_parquet(folder / f"{name}.parquet")
    assert list(table.columns) == COLUMNS
    assert len(table) == 5 * cycles and doc["cycles"] == cycles
    # Each cycle visits P5, P4, P3, P2, P1.
    assert table["test_pose"].tolist()[:5] == [5, 4, 3, 2, 1]
    assert sorted(set(table["cycle"])) == list(range(1, cycles + 1))
    again = recompute(folder / f"{name}.parquet")
    assert [p["test_pose"] for p in doc["poses"]] == [1, 2, 3, 4, 5]
    for p in doc["poses"]:
        ap, rp, comps = again[p["test_pose"]]
        assert abs(p["AP_mm"] - ap) < 1e-9 and abs(p["RP_mm"] - rp) < 1e-9
        for key, value in zip(("APx_mm", "APy_mm", "APz_mm"), comps, strict=True):
            assert abs(p[key] - value) < 1e-9
        assert p["RP_mm"] > 0
    assert doc["frame"] == "robot base" and doc["registration"]["frame"] == "robot base"
    assert doc["orientation"].startswith("not measured")
    assert not (folder / f"{name}.json.journal").exists()
    return doc
