"""``calibrator verify --path`` on the simulated cell: the streamed path test, before and after."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from cli_kit import cli, one_line_error

SEED = "3"
FAST = ("--cycles", "2", "--path-speed", "400")


@pytest.fixture(scope="module")
def cell(tmp_path_factory):
    """The hidden arm of SEED measured and identified, and its line test before and after."""
    folder = tmp_path_factory.mktemp("path")
    done = cli("measure", "-q", "--seed", SEED, "--poses", "60", "-o", "s.parquet", cwd=folder)
    assert done.code == 0, done.stderr
    done = cli("identify", "s.parquet", "-o", "cal.json", cwd=folder)
    assert done.code == 0, done.stderr
    before = cli("verify", "--seed", SEED, "--path", "line", *FAST, "-o", "b.json", cwd=folder)
    assert before.code == 0, before.stderr
    assert "AT_P" in before.stdout and "nominal commands" in before.stdout
    after = cli(
        "verify", "--seed", SEED, "--path", "line", *FAST, "--calibration", "cal.json",
        "-o", "a.json", cwd=folder,
    )  # fmt: skip
    assert after.code == 0, after.stderr
    return folder


def test_the_line_test_writes_its_figures_under_the_path_key(cell):
    doc = json.loads((cell / "b.json").read_text())
    path = doc["path"]
    assert doc["test"] == "path" and path["shape"] == "line" and path["cycles"] == 2
    assert len(path["points"]["AT_mm"]) == 100
    assert path["AT_P_mm"] == max(path["points"]["AT_mm"])
    # The hidden errors (+-0.5 mm, 1 mrad, a 1.5 mm tool error) stray the path by a
    # millimetre or more; the spread is the tracker's noise (no joint errors on a path).
    assert path["AT_P_mm"] > 0.5
    assert path["RT_P_mm"] < 0.05
    # A kinematic arm keeps the commanded speed along the path to a fraction of a percent.
    assert abs(path["AV_pct"]) < 1.0 and path["RV_pct"] < 0.5


def test_compensated_commands_cut_the_path_accuracy_error(cell):
    before = json.loads((cell / "b.json").read_text())["path"]
    after = json.loads((cell / "a.json").read_text())
    assert after["path"]["compensated"] and after["registration"]["method"] == "calibration"
    assert after["path"]["commanded"] == before["commanded"]
    assert after["path"]["AT_P_mm"] < 0.2 * before["AT_P_mm"], (before, after["path"])


def test_the_circle_test_runs_in_the_same_plane(tmp_path):
    done = cli("verify", "--seed", SEED, "--path", "circle", *FAST, "-o", "c.json", cwd=tmp_path)
    assert done.code == 0, done.stderr
    path = json.loads((tmp_path / "c.json").read_text())["path"]
    assert path["shape"] == "circle" and path["AT_P_mm"] > 0.5
    assert path["commanded"]["length_mm"] == pytest.approx(
        2 * 3.141592653589793 * path["commanded"]["radius_mm"]
    )


@pytest.mark.parametrize(
    "args, message",
    [
        (("--path", "square"), "--path must be one of line, circle, rectangle"),
        (("--path", "line", "--path-speed", "0"), "--path-speed must be in"),
        (("--path", "line", "--tracker", "socket://127.0.0.1:9"), "runs a timed path"),
        (("--path", "line", "--path-speed", "fast"), "--path-speed must be mm/s or a percentage"),
    ],
)
def test_path_options_it_cannot_run_are_refused_in_one_line(tmp_path, args, message):
    done = cli("verify", *args, "-o", "v.json", cwd=tmp_path)
    assert done.code == 2
    assert message in one_line_error(done)
    assert not (tmp_path / "v.json").exists()


def _crossing(p: np.ndarray, c: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Where the sampled path p (K, 3) crosses the plane through c normal to t, nearest c."""
    best, where = np.inf, None
    d = (p - c) @ t
    for k in np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:])):
        x = p[k] + d[k] / (d[k] - d[k + 1]) * (p[k + 1] - p[k])
        if np.linalg.norm(x - c) < best:
            best, where = np.linalg.norm(x - c), x
    return where


def test_the_recorded_rectangle_streams_give_the_same_figures_computed_independently(tmp_path):
    done = cli("verify", "--seed", SEED, "--path", "rectangle", *FAST, "-o", "r.json", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert "corners, mm" in done.stdout
    doc = json.loads((tmp_path / "r.json").read_text())
    path = doc["path"]
    table = pd.read_parquet(tmp_path / doc["data"])
    assert list(table.columns) == ["cycle", "n", "t_s", "x_mm", "y_mm", "z_mm"]
    cycles = [g[["x_mm", "y_mm", "z_mm"]].to_numpy() for _, g in table.groupby("cycle")]
    v = np.array(path["commanded"]["vertices_mm"])
    seg_len = np.linalg.norm(np.diff(v, axis=0), axis=1)
    starts = np.concatenate([[0.0], np.cumsum(seg_len)])
    at, rt = [], []
    for s in path["points"]["s_mm"]:
        k = min(np.searchsorted(starts, s, side="right") - 1, len(seg_len) - 1)
        t = (v[k + 1] - v[k]) / seg_len[k]
        c = v[k] + (s - starts[k]) * t
        x = np.array([_crossing(p, c, t) for p in cycles])
        bar = x.mean(axis=0)
        at.append(np.linalg.norm(bar - c))
        dist = np.linalg.norm(x - bar, axis=1)
        rt.append(dist.mean() + 3 * dist.std(ddof=1))
    assert path["AT_P_mm"] == pytest.approx(max(at), abs=1e-6)
    assert path["RT_P_mm"] == pytest.approx(max(rt), abs=1e-6)
    for j, corner in enumerate(v[1:-1]):
        u1 = (corner - v[j]) / seg_len[j]
        u2 = (v[j + 2] - corner) / seg_len[j + 1]
        out = u1 - (u1 @ u2) * u2
        out /= np.linalg.norm(out)
        cr, co = [], []
        for p in cycles:
            a, b = p[:-1] - corner, p[1:] - corner
            w = np.clip(-np.sum(a * (b - a), axis=1) / np.sum((b - a) ** 2, axis=1), 0, 1)
            cr.append(np.linalg.norm(a + w[:, None] * (b - a), axis=1).min())
            along = (p - corner) @ u2
            turned = (along >= 0) & (along <= seg_len[j + 1])
            co.append(max(0.0, ((p - corner) @ out)[turned].max()))
        assert path["CR_mm"][j] == pytest.approx(max(cr), abs=1e-6)
        assert path["CO_mm"][j] == pytest.approx(max(co), abs=1e-6)
