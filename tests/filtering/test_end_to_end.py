"""End to end: a simulated arm with hidden errors is identified, a RAPID program of
Cartesian targets in a work object with a tool is filtered, and the nominal
controller driving the true arm lands every filtered target on its intended pose."""

import re

import numpy as np
import pytest
from filter_kit import BASE, TOOL, job
from program_kit import rapid_pose, robtarget

from calibrator import session, simulate
from calibrator.calibration import Calibration
from calibrator.compensate import programs
from calibrator.identify import pipeline
from calibrator.model import frames, inverse, kinematics, rotations


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    table, meta, truth = simulate.simulate(
        model="er10l-c10", poses=60, seed=11, frame="base",
        noise_mm=0.001, orientation_noise_rad=1e-6,
    )  # fmt: skip
    path = tmp_path_factory.mktemp("s") / "s.parquet"
    session.write(path, table, meta)
    result = pipeline.identify(session.load(path), pipeline.Options(method="lm"))
    return Calibration.from_result(result, path, "er10l-c10", "base"), truth


def _module(path, cal, q):
    pose = np.linalg.inv(BASE) @ kinematics.tool_poses(cal.nominal_mdh, q, TOOL)
    lines = [
        "MODULE Cell",
        f"  PERS tooldata tSpindle:=[TRUE,{rapid_pose(TOOL)},[4,[0,0,80],[1,0,0,0],0,0,0]];",
        f'  PERS wobjdata wPart:=[FALSE,TRUE,"",{rapid_pose(BASE)},[[0,0,0],[1,0,0,0]]];',
    ]
    lines += [
        f"  CONST robtarget t{i}:={robtarget(cal, p, qi)};"
        for i, (p, qi) in enumerate(zip(pose, q, strict=True))
    ]
    lines += ["  PROC main()"] + [
        f"    MoveL t{i}, v100, fine, tSpindle\\WObj:=wPart;" for i in range(len(q))
    ]
    lines += ["  ENDPROC", "ENDMODULE", ""]
    path.write_text("\n".join(lines))
    return path


def _targets(text):
    num = r"([-\d.]+)"
    pat = rf"robtarget t\d+:=\[\[{num},{num},{num}\],\[{num},{num},{num},{num}\]"
    v = np.array([[float(x) for x in m] for m in re.findall(pat, text)])
    return BASE @ frames.transform(rotations.quaternion_to_matrix(v[:, 3:]), v[:, :3])


def test_filtered_program_lands_on_the_true_arm(identified, tmp_path):
    cal, truth = identified
    rng = np.random.default_rng(4)
    # Joints 1, 4, 6 inside one quadrant, clear of its edges: corrections of the
    # simulated arm's size would move a target near an edge into the next (refused).
    box = [(0.1, 1.4), (-0.1, 0.5), (-0.5, 0.1), (0.1, 1.4), (0.5, 1.4), (0.1, 1.4)]
    q = np.column_stack([rng.uniform(lo, hi, 30) for lo, hi in box])
    src = _module(tmp_path / "cell.mod", cal, q)
    out = tmp_path / "cell_filtered.mod"
    # The simulated arm's errors (about 0.5 deg per angle) are ten times a real
    # arm's: corrections reach 30 mm, past the default bound meant for real arms.
    summary = programs.Filter("rapid", job(cal, max_mm=60.0, max_deg=3.0), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    intended = _targets(src.read_text())

    def drive(sent):
        # The controller: nominal inverse kinematics in the same configuration
        # (started from the joints the targets were made from), on the true arm.
        sol = inverse.solve(cal.nominal_mdh, sent, q, TOOL)
        assert sol.converged.all()
        return kinematics.chain(truth.mdh, sol.q) @ TOOL

    filtered = drive(_targets(out.read_text()))
    unfiltered = drive(intended)
    err = np.linalg.norm(filtered[:, :3, 3] - intended[:, :3, 3], axis=1)
    raw = np.linalg.norm(unfiltered[:, :3, 3] - intended[:, :3, 3], axis=1)
    assert err.max() < 0.02, err.max()
    assert raw.min() > 0.5  # the arm's full error without the filter
    turn = rotations.rotation_error(filtered[:, :3, :3], intended[:, :3, :3])
    assert np.degrees(np.linalg.norm(turn, axis=1)).max() < 0.01
