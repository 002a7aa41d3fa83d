"""The targets CSV path: read, solved and written in blocks; swings near singularities refused."""

import numpy as np
import pandas as pd
import pytest
from cli_process_kit import run_cli

from calibrator import compensate, robots, simulate
from calibrator.calibration import Calibration
from calibrator.compensate import targets
from calibrator.errors import CalibrationError
from calibrator.model import parameters


def _calibration(seed=3):
    nominal = robots.get("ur10e").mdh
    errors = simulate.random_errors(nominal, np.random.default_rng(seed), mm=0.3, rad=0.0005)
    free = tuple(np.array(parameters.MDH_NAMES)[errors.ravel() != 0])
    return Calibration(
        nominal_mdh=nominal, mdh=nominal + errors, model="ur10e", free=free,
        deltas=dict(zip(free, errors.ravel()[errors.ravel() != 0], strict=True)),
    )  # fmt: skip


def _joints(n, seed=0):
    rng = np.random.default_rng(seed)
    box = [(-1.0, 1.0), (-2.2, -1.0), (0.6, 2.0), (-2.5, -0.5), (0.5, 2.5), (-3.0, 3.0)]
    return np.column_stack([rng.uniform(lo, hi, n) for lo, hi in box])


def _csv(path, q):
    pd.DataFrame(q, columns=compensate.JOINT_COLUMNS).to_csv(path, index=False)


def test_blocks_give_the_same_answer_as_one_call(tmp_path, monkeypatch):
    monkeypatch.setattr(targets, "BLOCK", 7)  # 30 targets: five blocks, the last short
    cal = _calibration()
    q = _joints(30)
    _csv(tmp_path / "t.csv", q)
    report = compensate.run(cal, tmp_path / "t.csv", tmp_path / "o.csv")
    out = pd.read_csv(tmp_path / "o.csv")
    whole = compensate.compensate(cal, None, q, robots.get("ur10e").joint_limits_rad)
    assert out["target"].tolist() == list(range(30))
    ok = (out["status"] == "ok").to_numpy()
    np.testing.assert_allclose(out.loc[ok, list(compensate.JOINT_COLUMNS)], whole.q[ok], atol=1e-9)
    assert report.lines[0].startswith(f"{ok.sum()} of 30 targets compensated")


def test_a_bad_cell_in_a_later_block_names_its_line(tmp_path, monkeypatch):
    monkeypatch.setattr(targets, "BLOCK", 4)
    _csv(tmp_path / "t.csv", _joints(10))
    text = (tmp_path / "t.csv").read_text().splitlines()
    text[9] = "0_5" + text[9][text[9].index(",") :]  # data row 9: file line 10
    (tmp_path / "t.csv").write_text("\n".join(text) + "\n")
    cal = _calibration()
    cal.save(tmp_path / "cal.json")
    done = run_cli("compensate", "cal.json", "t.csv", "-o", "o.csv", cwd=tmp_path)
    assert done.returncode == 2 and "line 10, q1_rad: '0_5'" in done.stderr
    assert not (tmp_path / "o.csv").exists()


def test_a_large_joint_change_near_the_wrist_singularity_is_refused(tmp_path):
    cal = _calibration()
    cal.save(tmp_path / "cal.json")
    q = _joints(3)[[0, 1, 2, 1]]
    q[1, 4] = np.radians(0.2)  # wrist axes 4 and 6 all but aligned
    q[3, 4] = np.radians(0.05)  # closer still: the calibrated arm has no solution
    _csv(tmp_path / "t.csv", q)
    done = run_cli("compensate", "cal.json", "t.csv", "-o", "o.csv", cwd=tmp_path)
    out = pd.read_csv(tmp_path / "o.csv")
    assert out["status"].tolist() == ["ok", "large joint change", "ok", "not reached"]
    assert done.returncode == 1
    assert "target 1: large joint change: joint" in done.stderr
    assert "wrist singularity: axes 4 and 6 are 0.20 deg from parallel" in done.stderr
    (line,) = [x for x in done.stderr.splitlines() if x.startswith("target 3: not reached")]
    assert line.endswith("; wrist singularity: axes 4 and 6 are 0.05 deg from parallel)")


def test_the_fast_reading_refuses_what_the_strict_grammar_refuses(tmp_path):
    # float() reads these; the strict grammar does not, nor does the block reader.
    for cell in ("1_0", "\u0661", "nan", "infinity", "1e400"):
        _csv(tmp_path / "t.csv", _joints(3))
        lines = (tmp_path / "t.csv").read_text(encoding="utf-8").splitlines()
        lines[2] = cell + lines[2][lines[2].index(",") :]
        (tmp_path / "t.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
        with pytest.raises(CalibrationError, match="line 3, q1_rad"):
            compensate.read_targets(tmp_path / "t.csv")
