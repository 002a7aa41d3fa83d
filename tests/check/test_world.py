"""World files: the simulated cell's true arm changed as written; bad files refused in one line."""

import numpy as np
import pytest
from cli_kit import cli, one_line_error

from calibrator.model import frames, kinematics, rotations
from calibrator.simulate import SimWorld
from calibrator.world import WorldError, parse_world, read_world

WORN = """\
world: 1
model: UR10e
seed: 4
arm:
  deltas: {a2: 0.25, alpha3: 2e-4}
joint_zero_shifts_rad: [0, 4e-4, 0, 0, 0, -1e-3]
base: {translation_mm: [1, 2, 3], rotvec_rad: [0, 0, 0.001]}
reflector_shift_mm: [0, 0.5, 0]
noise: false
repeatability: true
"""


def test_a_world_file_changes_the_seeds_arm_as_written(tmp_path):
    path = tmp_path / "worn.yaml"
    path.write_text(WORN)
    world = read_world(path)
    assert world.model == "ur10e" and world.seed == 4 and not world.noise and world.repeatability
    built = world.build("ur10e", seed=9)
    seed4 = SimWorld.make("ur10e", 4)
    change = built.true_mdh - seed4.true_mdh
    expected = np.zeros((6, 5))
    expected[1, kinematics.A] = 0.25
    expected[2, kinematics.ALPHA] = 2e-4
    expected[1, kinematics.THETA] = 4e-4
    expected[5, kinematics.THETA] = -1e-3
    np.testing.assert_allclose(change, expected, atol=1e-12)
    moved = frames.invert(seed4.base2tracker) @ built.base2tracker
    np.testing.assert_allclose(moved[:3, 3], [1, 2, 3], atol=1e-9)
    np.testing.assert_allclose(rotations.matrix_to_rotvec(moved[:3, :3]), [0, 0, 0.001], atol=1e-12)
    np.testing.assert_allclose(built.flange2tool[:3, 3] - seed4.flange2tool[:3, 3], [0, 0.5, 0])
    # The arm is the file's seed; the tracker's noise is the run's.
    assert built.seed == 4 and built.noise_seed == 9


def test_no_errors_is_the_nominal_arm_and_the_run_seed_is_used_without_one():
    built = parse_world({"arm": {"errors": "none"}}).build("ur10e", seed=2)
    np.testing.assert_array_equal(built.true_mdh, built.model.mdh)
    np.testing.assert_array_equal(built.base2tracker, SimWorld.make("ur10e", 2).base2tracker)


def test_errors_seed_is_the_old_spelling_of_drawn():
    # World files written before the rename say "errors: seed"; they give the same arm.
    old = parse_world({"seed": 4, "arm": {"errors": "seed"}})
    new = parse_world({"seed": 4, "arm": {"errors": "drawn"}})
    assert old.errors == new.errors == "drawn"
    np.testing.assert_array_equal(old.build("ur10e", 1).true_mdh, new.build("ur10e", 1).true_mdh)
    np.testing.assert_array_equal(
        parse_world({}).build("ur10e", 4).true_mdh, SimWorld.make("ur10e", 4).true_mdh
    )


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ([1, 2], "a world file is a mapping"),
        ({"wear": 1}, "unknown key(s) wear"),
        ({"world": 2}, "world: 2 is not a format"),
        ({"arm": {"deltas": {"q2": 0.1}}}, "'q2' is not an MDH parameter"),
        ({"arm": {"deltas": {"a2": 80.0}}}, "arm.deltas.a2: 80.0 mm is beyond 50 mm"),
        ({"arm": {"errors": "some"}}, "arm.errors: expected drawn or none"),
        ({"joint_zero_shifts_rad": [0, 0, 0]}, "expected a list of 6 numbers"),
        ({"base": {"translation_mm": [0, 0, ".nan"]}}, "base.translation_mm[2]: expected a finite"),
        ({"noise": "yes"}, "noise: expected true or false"),
        ({"seed": -1}, "seed: expected a non-negative integer"),
    ],
)
def test_bad_world_files_are_refused_naming_what_is_wrong(doc, message):
    with pytest.raises(WorldError, match=None) as err:
        parse_world(doc)
    assert message in str(err.value)


def test_another_models_world_is_refused():
    with pytest.raises(WorldError, match="for a ur5e, not --model ur10e"):
        parse_world({"model": "ur5e"}).build("ur10e", 0)


def test_measure_refuses_a_bad_world_file_in_one_line_and_writes_nothing(tmp_path):
    (tmp_path / "w.yaml").write_text("world: 1\narm: {deltas: {a2: oops}}\n")
    line = one_line_error(cli("measure", "--world", "w.yaml", "-o", "s.parquet", cwd=tmp_path))
    assert "w.yaml: arm.deltas.a2: expected a finite number (mm), got 'oops'" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.yaml"]


def test_a_file_without_its_world_line_is_no_world_file(tmp_path):
    # docs/check.md: every key but `world` is optional.
    (tmp_path / "w.yaml").write_text("arm: {deltas: {a2: 0.05}}\n")
    with pytest.raises(WorldError, match=r"w\.yaml: no 'world: 1' line: not a world file"):
        read_world(tmp_path / "w.yaml")


def test_a_quoted_number_is_text_and_refused(tmp_path):
    (tmp_path / "w.yaml").write_text("world: 1\narm: {deltas: {alpha3: '4e-4'}}\n")
    with pytest.raises(WorldError, match=r"arm\.deltas\.alpha3: expected a finite number"):
        read_world(tmp_path / "w.yaml")
    (tmp_path / "w.yaml").write_text("world: 1\narm: {deltas: {alpha3: 4e-4}}\n")
    assert read_world(tmp_path / "w.yaml").deltas == {"alpha3": 4e-4}


def test_a_world_file_is_for_the_simulated_cell_only(tmp_path):
    (tmp_path / "w.yaml").write_text("world: 1\n")
    result = cli(
        "verify", "--robot", "ur://10.0.0.9", "--tracker", "socket://10.0.0.8:1",
        "--world", "w.yaml", cwd=tmp_path,
    )  # fmt: skip
    assert "--world is for the simulated cell" in one_line_error(result)
