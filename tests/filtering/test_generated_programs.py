"""The programs ``calibrator program`` writes go through ``compensate`` as a user's would.

A measurement program moves in joints only, and a KRL one sets no ``$TOOL``:
its taught joint targets are kept (no frame needed), so the output is the
input byte for byte; corrected (``--joint-targets correct``) they need the
tool, and the filter says so.
"""

import pytest
from cli_kit import cli, listing

from calibrator import planning


@pytest.fixture(scope="module")
def folder(tmp_path_factory, checked_plan):
    folder = tmp_path_factory.mktemp("generated")
    planning.write_plan(folder / "plan.csv", checked_plan)
    for args in (
        ("simulate", "--poses", "30", "-o", "s.parquet"),
        ("identify", "s.parquet", "--method", "lm", "-q", "-o", "cal.json"),
    ):
        done = cli(*args, cwd=folder)
        assert done.code == 0, done.stderr
    return folder


@pytest.mark.parametrize("name", ["CAL.src", "cal.mod", "cal.ls", "cal.script"])
def test_joint_targets_are_kept_byte_for_byte(folder, name):
    done = cli("program", "plan.csv", "-o", name, "--force", cwd=folder)
    assert done.code == 0, done.stderr
    out = f"filtered_{name}"
    done = cli("compensate", "cal.json", name, "-o", out, "--force", cwd=folder)
    assert done.code == 0, done.stderr
    assert "0 failed" in done.stdout
    assert (folder / out).read_bytes() == (folder / name).read_bytes()


def test_correcting_krl_joint_targets_without_a_tool_names_the_line(folder):
    assert cli("program", "plan.csv", "-o", "J.src", "--force", cwd=folder).code == 0
    before = listing(folder)
    done = cli(
        "compensate", "cal.json", "J.src", "-o", "J_out.src", "--joint-targets", "correct",
        cwd=folder,
    )  # fmt: skip
    assert done.code == 1, done.stderr
    assert "J.src:" in done.stderr + done.stdout and "$TOOL" in done.stderr + done.stdout
    assert listing(folder) == before
