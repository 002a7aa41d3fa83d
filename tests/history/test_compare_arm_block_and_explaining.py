"""What the history keeps of a calibration to compare it, and how it names what moved.

``arm_block`` of real :class:`calibrator.calibration.Calibration` objects
(identified values, covariance with its correlations, the tool's angles);
``compare`` of states where more than two parameters moved (the greedy
search past pairs); ``state_of`` of rows as the history stores them. Found
by mutation testing (issue 44).
"""

from __future__ import annotations

import numpy as np
import pytest

from calibrator.calibration import Calibration, FitReport
from calibrator.history import compare
from calibrator.model import rotations


def _calibration(free, se, correlation=None, flange2tool=None, deltas=None):
    nominal = _ur10e()
    mdh = nominal.copy()
    mdh[1, 0] += 0.25  # a2 identified 0.25 mm longer
    mdh[3, 2] -= 2e-4  # theta4
    return Calibration(
        nominal_mdh=nominal,
        mdh=mdh,
        flange2tool=np.eye(4) if flange2tool is None else flange2tool,
        free=tuple(free),
        deltas=deltas or dict.fromkeys(free, 0.0),
        fit=FitReport(uncertainty={"standard_errors": se, "correlation": correlation}),
    )


def _ur10e():
    from calibrator.model import kinematics

    table = np.zeros((6, len(kinematics.COLUMNS)))
    table[:, kinematics.COLUMNS.index("a")] = [0, 0, 612.7, 571.55, 0, 0]
    return table


def test_the_arm_block_holds_identified_values_and_the_correlated_covariance():
    from calibrator.model import kinematics

    free = ("a2", "theta4", "tool_x", "tool_rx", "base_tx")
    se = {"a2": 0.02, "theta4": 1e-5, "tool_x": 0.05, "tool_rx": 2e-4, "base_tx": 0.1}
    correlation = {
        "names": ["theta4", "a2", "tool_x"],
        "matrix": [[1, -0.5, 0], [-0.5, 1, 0.9], [0, 0.9, 1]],
    }
    tool = np.eye(4)
    tool[:3, :3] = rotations.rotvec_to_matrix(np.array([[0.01, -0.02, 0.03]]))[0]
    tool[:3, 3] = [1.0, 2.0, 150.0]
    cal = _calibration(
        free, se, correlation, tool, {"base_tx": 0.7, **dict.fromkeys(free[:4], 0.0)}
    )
    block = compare.arm_block(cal)
    assert block["names"] == list(free)
    mdh = np.asarray(cal.mdh)
    angles = rotations.angles_xyz(tool[:3, :3])
    assert block["values"] == pytest.approx(
        [
            mdh[1, kinematics.COLUMNS.index("a")],
            mdh[3, kinematics.COLUMNS.index("theta")],
            1.0,
            angles[0],
            0.7,  # the base by its delta
        ]
    )
    cov = np.array(block["covariance"])
    assert np.allclose(np.diag(cov), [se[n] ** 2 for n in free])
    # Off the diagonal: correlation x both standard errors, where both are correlated.
    assert cov[0, 1] == pytest.approx(-0.5 * 0.02 * 1e-5)
    assert cov[1, 0] == pytest.approx(-0.5 * 0.02 * 1e-5)
    assert cov[0, 2] == pytest.approx(0.9 * 0.02 * 0.05)
    assert cov[1, 2] == 0.0 and cov[3, 0] == 0.0 and cov[4, 2] == 0.0
    assert block["base2tracker"] == np.eye(4).tolist()


def test_a_calibration_without_standard_errors_keeps_no_arm_block():
    assert compare.arm_block(_calibration(("a2",), {})) == {}
    # Only the parameters with a standard error are kept.
    block = compare.arm_block(_calibration(("a2", "theta4"), {"theta4": 1e-5}))
    assert block["names"] == ["theta4"] and np.allclose(block["covariance"], [[1e-10]])


def test_three_parameters_that_moved_are_all_named():
    """Singles and pairs cannot explain three independent moves: the greedy search names them."""
    names = ("a1", "a2", "a3", "a4", "a5")
    cov = np.eye(5) * 1e-4  # 0.01 mm each
    before = compare.State(names, np.zeros(5), cov)
    after = compare.State(names, np.array([0.2, 0.0, -0.3, 0.0, 0.25]), cov)
    found = compare.compare(before, after)
    assert found.moved and found.dof == 5
    assert sorted(c.name for c in found.changes) == ["a1", "a3", "a5"]
    by_name = {c.name: c for c in found.changes}
    assert by_name["a3"].change == pytest.approx(-0.3)
    assert by_name["a5"].standard_error == pytest.approx(np.sqrt(2e-4))


def test_an_older_row_compares_its_arm_parameters_with_their_standard_errors():
    row = {
        "parameters": {"a2": 0.1, "theta3": 2e-4, "tool_x": 0.3, "base_tx": 1.0, "d4": 0.0},
        "uncertainties": {"a2": 0.01, "theta3": 1e-5, "tool_x": 0.02, "base_tx": 0.1},
    }
    state = compare.state_of(row)
    assert state.names == ("a2", "theta3")
    assert np.allclose(state.values, [0.1, 2e-4])
    assert np.allclose(state.cov, np.diag([1e-4, 1e-10]))
    assert (state.tool, state.world, state.base2world) == (None, None, None)


def test_a_row_with_its_arm_block_and_set_up_gives_the_base_in_its_world():
    base = np.eye(4)
    base[:3, 3] = [10.0, 0.0, 0.0]
    shift = np.eye(4)
    shift[:3, 3] = [0.0, 5.0, 0.0]
    row = {
        "parameters": {"a2": 9.0},
        "statistics": {
            "arm": {"names": ["a2"], "values": [612.8], "covariance": [[1e-4]],
                    "base2tracker": base.tolist()},
            "setup": {"tool_id": "smr",
                      "tracker_pose": {"world": "cell", "tracker2world": shift.tolist()}},
        },
    }  # fmt: skip
    state = compare.state_of(row)
    assert state.names == ("a2",) and np.allclose(state.values, [612.8])
    assert (state.tool, state.world) == ("smr", "cell")
    assert np.allclose(state.base2world[:3, 3], [10.0, 5.0, 0.0])
