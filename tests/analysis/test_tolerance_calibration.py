"""``analyze tolerance``: no tolerance on what an arm does not have; a calibration's uncertainty."""

import json

import numpy as np
from analyze_kit import analyze, analyze_json
from cli_kit import refused_line
from cli_process_kit import run_cli

from calibrator import calibration


def test_beta_between_non_parallel_axes_is_never_ranked_nor_toleranced(tmp_path):
    out, doc = analyze_json(
        "tolerance", "--model", "ur10e", "--poses", "10", "--samples", "50",
        "--angle-tol", "0.5", "--json", "b.json", cwd=tmp_path,
    )  # fmt: skip
    ranked = {row["name"] for row in doc["ranking"]}
    # UR10e: axes 2, 3, 4 are parallel (beta2, beta3 are real), the others are not.
    assert {"beta2", "beta3"} <= ranked
    assert not {"beta1", "beta4", "beta5", "beta6"} & ranked
    assert [d["name"] for d in doc["not_toleranced"]] == ["beta1", "beta4", "beta5", "beta6"]
    assert "not toleranced (no physical quantity of this arm): beta1, beta4" in out.stdout
    refused = analyze("tolerance", "--model", "ur10e", "--tol", "beta1=0.1", cwd=tmp_path)
    assert refused_line(refused).endswith(
        "--tol beta1: no physical quantity of this arm "
        "(axes 1 and 2 are not parallel: the DH parameters already describe them)"
    )


def test_with_a_calibration_the_identified_standard_errors_are_the_tolerances(tmp_path):
    sim = run_cli("simulate", "-o", "s.parquet", "--poses", "30", cwd=tmp_path)
    assert sim.returncode == 0, sim.stderr
    ident = run_cli("identify", "s.parquet", "-o", "c.json", "--method", "lm", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    out, doc = analyze_json(
        "tolerance", "--calibration", "c.json", "--poses", "10", "--samples", "50",
        "--joint-tol", "0", "--json", "b.json", cwd=tmp_path,
    )  # fmt: skip
    cal = calibration.load(tmp_path / "c.json")
    errors = cal.fit.uncertainty["standard_errors"]
    assert doc["distribution"] == "normal"
    rows = {row["name"]: row for row in doc["ranking"]}
    identified = [n for n in cal.free if n in rows]
    assert len(identified) >= 15
    for name in identified:
        assert rows[name]["tolerance"] == 3.0 * errors[name]
    held = [n for n in rows if n not in errors and not n.startswith("q")]
    assert held and all(rows[n]["tolerance"] == 0.0 for n in held)
    assert f"tolerances of the {len(identified)} identified parameters: 3 x" in out.stdout
    # The identification's uncertainty is micrometres, far below a 0.05 mm band.
    band = analyze("tolerance", "--model", "ur10e", "--poses", "10", "--samples", "50",
                   "--joint-tol", "0", "--json", "m.json", cwd=tmp_path)  # fmt: skip
    assert band.returncode == 0, band.stderr
    assert doc["rms_mm"] < 0.2 * json.loads((tmp_path / "m.json").read_text())["rms_mm"]
    assert np.isfinite(doc["worst_case_mm"])
