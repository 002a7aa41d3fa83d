"""``--base-link``/``--tip-link`` name a URDF's chain wherever ``--model`` is given."""

import pandas as pd
import pytest
from cli_kit import cli, one_line_error
from robot_files_kit import KUKA, on_a_track

#: Every command with --model, with what else it needs to reach its model.
COMMANDS = [
    ["plan", "--poses", "12"],
    ["program", "plan.csv", "-o", "arm.script"],
    ["measure", "--poses", "12"],
    ["verify"],
    ["check", "--calibration", "cal.json"],
    ["identify", "session.parquet"],
    ["simulate"],
    ["analyze", "tolerance"],
    ["analyze", "misalignment"],
    ["analyze", "deflection"],
]


@pytest.mark.parametrize("command", COMMANDS, ids=lambda c: " ".join(c[:2]))
def test_links_without_a_urdf_model_are_refused_in_one_line(tmp_path, command):
    result = cli(*command, "--model", "ur10e", "--base-link", "base_link", cwd=tmp_path)
    assert "--base-link and --tip-link go with a URDF --model, not 'ur10e'" in one_line_error(
        result
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_links_given_twice_are_refused_in_one_line(tmp_path):
    (tmp_path / "arm.urdf").write_text(KUKA)
    named = f"{tmp_path / 'arm.urdf'}#base_link:tool0"
    result = cli("plan", "--model", named, "--tip-link", "tool0", cwd=tmp_path)
    assert "names its links already: give them once" in one_line_error(result)
    assert not (tmp_path / "plan.csv").exists()


def test_the_base_link_option_chooses_the_chain(tmp_path):
    # With the track's world link as the base, the chain has a prismatic joint.
    (tmp_path / "arm.urdf").write_text(on_a_track(KUKA))
    urdf = str(tmp_path / "arm.urdf")
    result = cli("plan", "--model", urdf, "--base-link", "world", "--poses", "12", cwd=tmp_path)
    assert "joint 'track' is prismatic" in one_line_error(result)
    # From the arm's own base to tool0 it is the six-axis arm, and the plan says so.
    done = cli(
        "plan",
        "--model",
        urdf,
        "--base-link",
        "base_link",
        "--tip-link",
        "tool0",
        "--poses",
        "12",
        cwd=tmp_path,
    )
    assert done.code == 0, done.stderr
    plan = pd.read_csv(tmp_path / "plan.csv")
    assert set(plan["model"]) == {f"{urdf}#base_link:tool0"}
