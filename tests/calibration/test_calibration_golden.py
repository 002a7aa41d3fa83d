"""calibration.json is byte for byte the golden file, and a calibration is never changed.

The golden file was written by the program before its documents were frozen
and their statistics typed: the same inputs must keep giving the same bytes,
and the files a user already has must read and write back unchanged.
"""

from dataclasses import FrozenInstanceError, replace
from pathlib import Path

import numpy as np
import pytest

from calibrator import calibration, robots
from calibrator.recorded_options import JointTermOptions, Options

GOLDEN = Path(__file__).parent / "golden"
NOMINAL = robots.get("ur10e").mdh


def tool():
    out = np.eye(4)
    out[:3, 3] = [1.5, -2.0, 150.0]
    return out


def fit_report():
    after = {"mean": 0.02, "std": 0.01, "max": 0.04}
    stats = {
        part: {
            "before": {"n": 8, "position_mm": {"mean": 0.5, "std": 0.25, "max": 1.0}},
            "after": {"n": 8, "position_mm": after},
        }
        for part in ("fit", "validation")
    }
    uncertainty = {
        "standard_errors": {"a2": 0.003, "alpha3": 1e-5},
        "correlation": {"names": ["a2", "alpha3"], "matrix": [[1.0, 0.5], [0.5, 1.0]]},
        "strong_correlations": [],
        "residual_sigma": {"position_mm": 0.01, "orientation_rad": None},
        "position_dof": 40.0,
        "predicted_validation_mm": {
            "model_rms_mean": 0.01,
            "model_rms_max": 0.02,
            "error_mean": 0.03,
            "noise_floor": 0.02,
        },
    }
    swarm = {"particles": 20, "generations": 20, "poses": 32, "loss": "lsq"}
    solver = {
        "loss": "lsq",
        "pso": {"objective": 2.0, "evaluations": 420, **swarm},
        "least_squares": {"objective": 0.5, "evaluations": 12, "message": "converged"},
        "convergence": [[0, 9.0], [20, 2.0]],
    }
    return calibration.FitReport(
        stats=stats,
        uncertainty=uncertainty,
        warnings=["a warning"],
        outliers=[3],
        validation_poses=[0, 5],
        solver=solver,
        fitted_joint_ranges_rad=[[-1.0, 1.0]] * 6,
    )


def golden_calibration():
    mdh = NOMINAL.copy()
    mdh[1, 0] += 0.25
    mdh[2, 1] -= 0.001
    provenance = calibration.Provenance(
        session_sha256="0" * 64,
        options=Options(
            method="hybrid",
            loss="lsq",
            seed=1,
            validation_fraction=0.2,
            k=0.0,
            noise_mm=0.05,
            tool_known=True,
            particles=20,
            generations=20,
            swarm_poses=32,
        ),
        joint=JointTermOptions(joint_term_groups=(), payload_com_mm=(0.0, 0.0, 0.0)),
        versions={"calibrator": "x"},
        created="2023-11-14T22:13:20+00:00",
    )
    return calibration.Calibration(
        nominal_mdh=NOMINAL,
        mdh=mdh,
        flange2tool=tool(),
        tool0=tool(),
        free=("a2", "alpha3"),
        deltas={"a2": 0.25, "alpha3": -0.001},
        dropped=[{"name": "d2", "reason": "parallel axes"}],
        model="ur10e",
        session="s.parquet",
        provenance=provenance,
        fit=fit_report(),
        diagnostics={"sessions": ["a.parquet", "b.parquet"]},
    )


def test_a_calibration_saves_to_the_golden_bytes(tmp_path):
    golden_calibration().save(tmp_path / "c.json")
    assert (tmp_path / "c.json").read_bytes() == (GOLDEN / "calibration.json").read_bytes()


def test_the_golden_calibration_reads_and_writes_back_unchanged(tmp_path):
    back = calibration.load(GOLDEN / "calibration.json")
    assert back.fit == fit_report() and back.provenance == golden_calibration().provenance
    assert back.fit.stats["validation"]["after"]["position_mm"]["mean"] == 0.02
    assert back.fit.uncertainty["standard_errors"] == {"a2": 0.003, "alpha3": 1e-5}
    assert back.fit.solver["least_squares"]["message"] == "converged"
    back.save(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_bytes() == (GOLDEN / "calibration.json").read_bytes()


def test_a_calibration_is_derived_never_changed():
    cal = golden_calibration()
    with pytest.raises(FrozenInstanceError):
        cal.model = None  # type: ignore[misc]
    with pytest.raises(FrozenInstanceError):
        cal.fit.warnings = []  # type: ignore[misc]
    with pytest.raises(ValueError, match="read-only"):
        cal.flange2tool[0, 3] = 9.0
    other = replace(cal, model=None, fit=replace(cal.fit, warnings=[]))
    assert other.model is None and other.fit.warnings == [] and other.fit.outliers == [3]
    assert cal.model == "ur10e" and cal.fit.warnings == ["a warning"]
    assert cal.to_json() != other.to_json()
