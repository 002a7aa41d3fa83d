"""The parameter vector's meaning, written out by hand and with scipy's rotations."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibrator import robots
from calibrator.errors import IdentifiabilityError
from calibrator.model import frames, parameters
from calibrator.model.parameters import ALL_NAMES, ParameterSpace


def test_every_name_has_its_unit_and_plausible_size():
    expected = {}
    for j in range(1, 7):
        expected.update({f"a{j}": "mm", f"alpha{j}": "rad", f"theta{j}": "rad"})
        expected.update({f"d{j}": "mm", f"beta{j}": "rad"})
    expected.update({f"base_t{c}": "mm" for c in "xyz"})
    expected.update({f"base_r{c}": "rad" for c in "xyz"})
    expected.update({f"tool_{c}": "mm" for c in "xyz"})
    expected.update({f"tool_r{c}": "rad" for c in "xyz"})
    assert len(ALL_NAMES) == 42 and set(ALL_NAMES) == set(expected)
    for name, u in expected.items():
        assert parameters.unit(name) == u, name
    assert parameters.plausible_range("d3") == 1.0
    assert parameters.plausible_range("beta2") == 0.01
    assert parameters.plausible_range("base_ty") == 5.0
    assert parameters.plausible_range("base_tx") == 5.0
    assert parameters.plausible_range("tool_z") == 5.0
    assert parameters.plausible_range("tool_ry") == 0.02
    assert parameters.plausible_range("base_rz") == 0.02


def test_free_names_are_checked_deduplicated_and_put_in_canonical_order():
    nominal = robots.get("ur5e").mdh
    with pytest.raises(ValueError, match=r"unknown parameter names: \['a7', 'tool'\]"):
        ParameterSpace(nominal, free=("a1", "a7", "tool"))
    space = ParameterSpace(nominal, free=("tool_x", "d2", "base_rx", "a1", "d2"))
    assert space.free == ("a1", "d2", "base_rx", "tool_x")
    assert space.size == 4
    np.testing.assert_array_equal(space.index, [0, 8, 33, 36])
    assert space.units == ("mm", "mm", "rad", "mm")
    base0 = frames.transform(translation=[3000.0, 0.0, 0.0])
    tool0 = frames.transform(translation=[0.0, 0.0, 80.0])
    other = ParameterSpace(nominal, base0, tool0, ("a1",)).with_free(["theta6", "tool_rz"])
    assert other.free == ("theta6", "tool_rz")
    np.testing.assert_array_equal(other.nominal_mdh, nominal)
    np.testing.assert_array_equal(other.base0, base0)
    np.testing.assert_array_equal(other.tool0, tool0)
    with pytest.raises(ValueError, match=r"must end in 4, got \(3,\)"):
        space.expand(np.zeros(3))
    full = space.expand(np.array([[1, 2, 3, 4]]))
    assert full.shape == (1, 42) and full.dtype == np.float64
    assert full[0, 0] == 1 and full[0, 8] == 2 and full[0, 33] == 3 and full[0, 36] == 4
    assert np.count_nonzero(full) == 4


def test_unpack_builds_the_frames_the_docstring_names():
    rng = np.random.default_rng(0)
    base0 = frames.transform(Rotation.from_rotvec([0.2, 1.0, -0.4]).as_matrix(), [2800, -50, 20])
    tool0 = frames.transform(Rotation.from_rotvec([0.5, 0.0, 0.3]).as_matrix(), [5, 6, 140])
    nominal = robots.get("er10l-c10").mdh
    space = ParameterSpace(nominal, base0, tool0, ALL_NAMES)
    x = rng.normal(0, 0.05, 42)
    mdh, base, tool = space.unpack(x)
    np.testing.assert_allclose(mdh, nominal + x[:30].reshape(6, 5), atol=1e-15)
    # base2tracker = base0 . Trans(tx, ty, tz) . Rx . Ry . Rz (moving axes: scipy "XYZ").
    delta = np.eye(4)
    delta[:3, :3] = Rotation.from_euler("XYZ", x[33:36]).as_matrix()
    delta[:3, 3] = x[30:33]
    np.testing.assert_allclose(base, base0 @ delta, atol=1e-9)
    # Tool point: first guess plus the deltas in the flange frame; rotation R(tool0) Rx Ry Rz.
    np.testing.assert_allclose(tool[:3, 3], tool0[:3, 3] + x[36:39], atol=1e-12)
    np.testing.assert_allclose(
        tool[:3, :3], tool0[:3, :3] @ Rotation.from_euler("XYZ", x[39:42]).as_matrix(), atol=1e-12
    )
    np.testing.assert_array_equal(tool[3], [0, 0, 0, 1])
    # Without a tool turn, the tool rotation is the first guess's, unchanged.
    _, _, still = space.unpack(np.where(np.arange(42) >= 39, 0.0, x))
    np.testing.assert_array_equal(still[:3, :3], tool0[:3, :3])
    # pack undoes unpack.
    np.testing.assert_allclose(space.pack(mdh, base, tool), x, atol=1e-12)
    np.testing.assert_array_equal(space.pack(), np.zeros(42))


def test_pack_of_frames_alone_and_of_the_table_alone():
    base0 = frames.transform(Rotation.from_rotvec([0.0, 0.0, 1.2]).as_matrix(), [3000, 0, 0])
    space = ParameterSpace(robots.get("ur10e").mdh, base0, np.eye(4), ALL_NAMES)
    turn = Rotation.from_euler("XYZ", [0.01, -0.02, 0.03]).as_matrix()
    moved = base0 @ frames.transform(turn, [1.0, -2.0, 3.0])
    x = space.pack(base2tracker=moved)
    np.testing.assert_allclose(x[30:36], [1.0, -2.0, 3.0, 0.01, -0.02, 0.03], atol=1e-12)
    assert np.count_nonzero(np.abs(x) > 1e-15) == 6
    tool = frames.transform(Rotation.from_euler("XYZ", [0.0, 0.05, 0.0]).as_matrix(), [0, 0, 90])
    y = space.pack(flange2tool=tool)
    np.testing.assert_allclose(y[36:], [0, 0, 90, 0, 0.05, 0], atol=1e-12)
    mdh = robots.get("ur10e").mdh.copy()
    mdh[2, 3] += 0.7
    z = space.pack(mdh=mdh)
    assert z[13] == pytest.approx(0.7) and np.count_nonzero(z) == 1


def test_search_box_by_block_and_unit():
    space = ParameterSpace(
        robots.get("ur5e").mdh, free=("a1", "alpha1", "base_tx", "base_rx", "tool_x", "tool_rz")
    )
    lower, upper = space.bounds()
    np.testing.assert_array_equal(upper, [2.0, 0.04, 10.0, 0.04, 10.0, 0.04])
    np.testing.assert_array_equal(lower, -upper)
    lower, upper = space.bounds(mm=1, rad=2, frame_mm=3, frame_rad=4)
    np.testing.assert_array_equal(upper, [1, 2, 3, 4, 3, 4])


def test_structural_reasons_name_the_axes_and_the_rule():
    _, dropped = parameters.structural_candidates(robots.get("ur10e").mdh, "base", False, True)
    reasons = {d["name"]: d["reason"] for d in dropped}
    assert reasons["d2"] == "axes 2 and 3 are parallel: beta2 is identified instead (Hayati)"
    assert reasons["d3"] == "axes 3 and 4 are parallel: beta3 is identified instead (Hayati)"
    assert reasons["beta1"] == (
        "axes 1 and 2 are not parallel: the DH parameters already describe them"
    )
    assert reasons["a6"] == (
        "the tool frame (point and rotation) is identified: joint 6's constant part belongs to it"
    )
    assert reasons["beta6"] == (
        "no axis after joint 6: a turn about the flange y axis belongs to the tool frame"
    )
    candidates, _ = parameters.structural_candidates(robots.get("ur10e").mdh, "base", False, True)
    assert not any(n.startswith("base_") for n in candidates)
    assert candidates[-6:] == ["tool_x", "tool_y", "tool_z", "tool_rx", "tool_ry", "tool_rz"]


def test_prune_names_the_kept_parameters_a_redundant_one_is_made_of():
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(40, 4))
    # d4 = 2 a1 - 3 alpha1 exactly; theta2 independent.
    jac[:, 2] = 2 * jac[:, 0] - 3 * jac[:, 1]
    kept, dropped = parameters.prune(["a1", "alpha1", "d4", "theta2"], jac, context="by design")
    assert kept == ["a1", "alpha1", "theta2"]
    assert len(dropped) == 1 and dropped[0]["name"] == "d4"
    assert dropped[0]["reason"] in (
        "redundant with alpha1, a1 by design",
        "redundant with a1, alpha1 by design",
    )
    # Frames are visited first: with base_tx = a1, a1 is the one dropped.
    jac2 = rng.normal(size=(30, 2))
    jac2[:, 1] = jac2[:, 0]
    kept, dropped = parameters.prune(["a1", "base_tx"], jac2)
    assert kept == ["base_tx"]
    assert dropped == [{"name": "a1", "reason": "redundant with base_tx for these poses"}]


def test_prune_keeps_a_column_just_outside_the_span_and_drops_one_inside():
    rng = np.random.default_rng(2)
    base = rng.normal(size=(50, 1))
    other = rng.normal(size=(50, 1))
    other -= base * (base.T @ other) / (base.T @ base)
    other /= np.linalg.norm(other)
    unit_base = base / np.linalg.norm(base)
    for tilt, kept_expected in ((1e-4, ["a1", "a2"]), (1e-8, ["a1"])):
        col = unit_base + tilt * other
        kept, _ = parameters.prune(["a1", "a2"], np.column_stack([base, col]))
        assert kept == kept_expected, tilt
    # A smaller tolerance keeps what the default drops.
    kept, _ = parameters.prune(
        ["a1", "a2"], np.column_stack([base, unit_base + 1e-8 * other]), 1e-9
    )
    assert kept == ["a1", "a2"]


def test_enough_residuals_is_at_least_one_per_free_parameter():
    parameters.require_enough(24, 24)
    with pytest.raises(IdentifiabilityError) as info:
        parameters.require_enough(23, 24, what="the fitting poses")
    assert str(info.value) == (
        "23 measured values from the fitting poses cannot identify 24 free parameters; "
        "measure more poses"
    )


def test_a_space_built_from_lists_holds_checked_arrays():
    nominal = robots.get("ur5e").mdh
    base0 = frames.transform(translation=[3000.0, 0.0, 0.0])
    space = ParameterSpace(nominal.tolist(), base0.tolist(), np.eye(4).tolist(), ("a1",))
    for value, expected in ((space.nominal_mdh, nominal), (space.base0, base0)):
        assert isinstance(value, np.ndarray) and value.dtype == np.float64
        np.testing.assert_array_equal(value, expected)
    assert isinstance(space.tool0, np.ndarray)
    with pytest.raises(ValueError, match=r"^base0 must have a last row"):
        ParameterSpace(nominal, np.zeros((4, 4)))
    with pytest.raises(ValueError, match=r"^tool0 rotation part is not a proper rotation"):
        ParameterSpace(nominal, np.eye(4), np.diag([1.0, 1.0, -1.0, 1.0]))


def test_kept_names_come_back_in_table_order_not_by_spelling():
    rng = np.random.default_rng(3)
    kept, dropped = parameters.prune(["d1", "theta1", "beta2", "a2"], rng.normal(size=(20, 4)))
    assert kept == ["theta1", "d1", "a2", "beta2"] and dropped == []


def test_no_effect_is_judged_relative_to_the_largest_column():
    rng = np.random.default_rng(4)
    big = rng.normal(size=(30, 3)) * 1e4
    big[:, 1] = rng.normal(size=30) * 1e-12  # round-off next to columns of 1e4
    kept, dropped = parameters.prune(["a1", "theta4", "d4"], big)
    assert kept == ["a1", "d4"]
    assert dropped == [{"name": "theta4", "reason": "has no effect on any measured pose"}]
    small = rng.normal(size=(30, 2)) * 1e-6
    small[:, 1] *= 1e-4  # 1e-10: small, but a real effect among columns of 1e-6
    assert parameters.prune(["a1", "d4"], small)[0] == ["a1", "d4"]
    # Nothing measured at all: every candidate has no effect.
    kept, dropped = parameters.prune(["a1", "d4"], np.zeros((12, 2)))
    assert kept == [] and [d["name"] for d in dropped] == ["a1", "d4"]
    assert parameters.prune([], np.zeros((12, 0))) == ([], [])


def test_redundancy_is_judged_on_columns_scaled_to_unit_length():
    rng = np.random.default_rng(5)
    base = rng.normal(size=(40, 1))
    other = rng.normal(size=(40, 1))
    other -= base * (base.T @ other) / (base.T @ base)
    # Long columns: 1e-8 relative out of the span is still redundant.
    col = 1000.0 * (base / np.linalg.norm(base) + 1e-8 * other / np.linalg.norm(other))
    kept, _ = parameters.prune(["a1", "a2"], np.column_stack([1000.0 * base, col]))
    assert kept == ["a1"]


def test_a_redundant_column_names_at_most_three_partners():
    rng = np.random.default_rng(6)
    jac = rng.normal(size=(40, 5))
    jac[:, 4] = jac[:, 0] + 2 * jac[:, 1] + 3 * jac[:, 2] + 4 * jac[:, 3]
    kept, dropped = parameters.prune(["a1", "alpha1", "theta1", "d1", "a2"], jac)
    assert kept == ["a1", "alpha1", "theta1", "d1"]
    reason = dropped[0]["reason"]
    assert reason.startswith("redundant with ") and reason.endswith(" for these poses")
    names = reason.removeprefix("redundant with ").removesuffix(" for these poses").split(", ")
    assert len(names) == 3 and set(names) <= {"a1", "alpha1", "theta1", "d1"}
    assert "a1" not in names  # the smallest share (scaled columns) is left out


def test_the_default_wording_names_the_poses():
    with pytest.raises(IdentifiabilityError, match=r"^5 measured values from the poses cannot"):
        parameters.require_enough(5, 6)
