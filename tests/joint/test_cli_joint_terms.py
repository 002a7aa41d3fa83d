"""``identify --joint-terms`` and ``compensate`` as a user runs them, on simulated arms."""

import json

import numpy as np
import pandas as pd
import pytest
from cli_kit import cli, listing, one_line_error
from joint_kit import sessions

from calibrator import session
from calibrator.model import joint_terms, kinematics, rotations
from calibrator.robots import masses as robot_masses

WRIST = joint_terms.JointTerms(
    np.array([0, 0, 0, 1e-3, 2e-3, -1.5e-3]), np.zeros(6), np.zeros(6), np.zeros(6)
)
SAGGY = joint_terms.JointTerms(
    np.zeros(6), np.zeros(6), np.zeros(6), np.array([0, 4e-6, 6e-6, 0, 0, 0])
)


def _write(folder, terms, payloads=(0.0,), poses=40, seed=3):
    parts, truth = sessions(terms, poses=poses, seed=seed, payloads_kg=payloads)
    names = []
    for i, (s, _, _) in enumerate(parts):
        name = f"s{i}.parquet"
        session.write(folder / name, s.table, s.meta)
        names.append(name)
    return names, truth


def _targets(folder, truth, n=15, seed=9):
    """Desired tool poses (base frame) inside the workspace, with nominal joint starts."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-2.5, 2.5, (n, 6))
    q[:, 2] = rng.uniform(-2.5, -0.5, n)  # elbow bent: far from singular poses
    pose = kinematics.forward(truth["mdh"], q, truth["tool"])
    rotvec = rotations.matrix_to_rotvec(pose[:, :3, :3])
    table = {f"q{j + 1}_rad": q[:, j] for j in range(6)}
    table.update(zip(("x_mm", "y_mm", "z_mm"), pose[:, :3, 3].T, strict=True))
    table.update(zip(("rx_rad", "ry_rad", "rz_rad"), rotvec.T, strict=True))
    pd.DataFrame(table).to_csv(folder / "targets.csv", index=False)
    return pose


def _reached(folder, truth, terms, payload_kg=0.0):
    """Where the true arm puts the tool at the compensated joints (mm off each target)."""
    out = pd.read_csv(folder / "out.csv")
    assert (out["status"] == "ok").all()
    q_cmd = out[[f"q{j}_rad" for j in range(1, 7)]].to_numpy()
    tau = joint_terms.gravity_torques(
        truth["mdh"] * 0 + _nominal(), q_cmd, robot_masses.get("ur10e"), payload_kg, [0, 0, 100]
    )
    q_true = joint_terms.effective(q_cmd, terms.vector(), tau)
    return kinematics.forward(truth["mdh"], q_true, truth["tool"])


def _nominal():
    from calibrator import robots

    return robots.get("ur10e").mdh


def test_identify_keeps_wrist_scale_terms_and_compensate_reaches_targets(tmp_path):
    names, truth = _write(tmp_path, WRIST)
    out = cli(
        "identify", *names, "--joint-terms", "scale,harmonic", "--method", "lm",
        "--noise-mm", "0.02", "-o", "cal.json", cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    assert "scale      kept" in out.stdout and "harmonic   not kept" in out.stdout
    assert "geometry alone position" in out.stdout
    doc = json.loads((tmp_path / "cal.json").read_text())
    np.testing.assert_allclose(doc["joint_terms"]["scale"], WRIST.scale, atol=3e-5)
    assert not any(n.startswith("scale") for n in doc["free_parameters"])

    desired = _targets(tmp_path, truth)
    done = cli("compensate", "cal.json", "targets.csv", "-o", "out.csv", cwd=tmp_path)
    assert done.code == 0, done.stdout + done.stderr
    reached = _reached(tmp_path, truth, WRIST)
    miss = np.linalg.norm(reached[:, :3, 3] - desired[:, :3, 3], axis=1)
    assert miss.max() < 0.05, miss  # the data's noise is 0.02 mm

    exported = cli("export-params", "cal.json", "-o", "cal.urdf", cwd=tmp_path)
    assert "cannot hold the joint terms (scale)" in exported.stderr


def test_compliance_from_two_payloads_and_compensate_at_a_third(tmp_path):
    names, truth = _write(tmp_path, SAGGY, payloads=(0.0, 10.0), poses=40)
    out = cli(
        "identify", *names, "--joint-terms", "compliance", "--method", "lm", "--noise-mm", "0.02",
        "--payload-com-mm", "0,0,100", "-o", "cal.json", cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    assert "compliance kept" in out.stdout
    doc = json.loads((tmp_path / "cal.json").read_text())
    comp = doc["joint_terms"]["compliance"]
    assert comp["mass_model"] == "ur10e" and comp["payload_com_mm"] == [0, 0, 100]
    se = doc["uncertainty"]["standard_errors"]
    for j, value in enumerate(comp["rad_per_Nm"]):
        if f"comp{j + 1}" in se:  # within its standard errors of the truth
            assert abs(value - SAGGY.compliance[j]) < 3 * se[f"comp{j + 1}"]
    assert {"comp2", "comp3"} <= set(se)

    desired = _targets(tmp_path, truth)
    done = cli(
        "compensate", "cal.json", "targets.csv", "-o", "out.csv", "--payload-kg", "5",
        cwd=tmp_path,
    )  # fmt: skip
    assert done.code == 0, done.stdout + done.stderr
    miss = np.linalg.norm(
        _reached(tmp_path, truth, SAGGY, 5.0)[:, :3, 3] - desired[:, :3, 3], axis=1
    )
    assert miss.max() < 0.05, miss
    # The payload matters: compensating for the wrong one misses by more.
    (tmp_path / "out.csv").unlink()
    cli("compensate", "cal.json", "targets.csv", "-o", "out.csv", "--payload-kg", "0", cwd=tmp_path)
    wrong = np.linalg.norm(
        _reached(tmp_path, truth, SAGGY, 5.0)[:, :3, 3] - desired[:, :3, 3], axis=1
    )
    assert wrong.max() > 3 * miss.max()


def test_terms_are_not_kept_without_joint_errors(tmp_path):
    names, _ = _write(tmp_path, joint_terms.JointTerms.zero(), seed=12)
    out = cli(
        "identify", *names, "--joint-terms", "scale", "--method", "lm", "--noise-mm", "0.02",
        "-o", "cal.json", cwd=tmp_path,
    )  # fmt: skip
    assert out.code == 0, out.stderr
    assert "scale      not kept" in out.stdout
    assert "joint_terms" not in json.loads((tmp_path / "cal.json").read_text())


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--joint-terms", "scale,backlash"], "--joint-terms"),
        (["--joint-terms", "scale", "--payload-com-mm", "1,2"], "--payload-com-mm"),
        (["--payload-kg", "-1"], "--payload-kg"),
    ],
)
def test_bad_joint_term_options_are_one_line(tmp_path, args, needle):
    names, _ = _write(tmp_path, WRIST, poses=12)
    before = listing(tmp_path)
    line = one_line_error(cli("identify", *names, *args, "-o", "cal.json", cwd=tmp_path))
    assert needle in line
    assert listing(tmp_path) == before


def test_sessions_of_different_arms_are_refused(tmp_path):
    names, _ = _write(tmp_path, WRIST, poses=12)
    other, _ = sessions(WRIST, poses=12, model="ur5e")
    session.write(tmp_path / "other.parquet", other[0][0].table, other[0][0].meta)
    line = one_line_error(
        cli("identify", names[0], "other.parquet", "-o", "cal.json", cwd=tmp_path)
    )
    assert "other.parquet" in line and "same arm" in line


def test_compensate_warns_about_targets_outside_the_fitted_joint_ranges(tmp_path):
    names, truth = _write(tmp_path, WRIST, poses=30)
    assert cli("identify", *names, "--method", "lm", "-o", "cal.json", cwd=tmp_path).code == 0
    doc = json.loads((tmp_path / "cal.json").read_text())
    assert np.shape(doc["fitted_joint_ranges_rad"]) == (6, 2)
    _targets(tmp_path, truth)
    ok = cli("compensate", "cal.json", "targets.csv", "-o", "out.csv", cwd=tmp_path)
    assert "outside the fitted joint ranges" not in ok.stdout
    doc["fitted_joint_ranges_rad"][2] = [-0.6, -0.5]  # as if the elbow had barely moved
    (tmp_path / "narrow.json").write_text(json.dumps(doc))
    (tmp_path / "out.csv").unlink()
    out = cli("compensate", "narrow.json", "targets.csv", "-o", "out.csv", cwd=tmp_path)
    assert out.code == 0, out.stderr
    assert "target poses lie outside the fitted joint ranges (q3 by up to" in out.stdout
