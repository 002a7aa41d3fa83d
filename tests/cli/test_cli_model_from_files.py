"""The arm is the one the input file names: a KUKA's plan and calibration need no --model.

A KUKA KR 6 is planned, measured and identified once (simulated cell); then
``program``, ``measure --plan``, ``check``, ``verify``, ``report`` and
``export-params`` run on its files without ``--model`` and work on the
KUKA, and each refuses a ``--model ur10e`` in one line naming both arms
and the file, writing nothing.
"""

import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml
from cli_kit import cli, listing, one_line_error

from calibrator import calibration, session
from calibrator.robots import shipped
from calibrator.robots import urdf as robot_urdf

ARM = "kuka-kr6-r900"


@pytest.fixture(scope="module")
def kuka(tmp_path_factory):
    """A folder with a KUKA's plan.csv, session.parquet and cal.json (simulated cell)."""
    folder = tmp_path_factory.mktemp("kuka")
    steps = [
        ("plan", "--model", ARM, "-o", "plan.csv", "--poses", "30", "--tracker-at",
         "2500,400,300"),
        ("measure", "--plan", "plan.csv", "-o", "session.parquet", "-q"),
        ("identify", "session.parquet", "-o", "cal.json", "--method", "lm", "-q"),
    ]  # fmt: skip
    for step in steps:
        done = cli(*step, cwd=folder)
        assert done.code == 0, (step, done.stderr)
    return folder


#: Each command on the KUKA's files, as a user types it without --model.
COMMANDS = {
    "program": ("program", "plan.csv", "-o", "cell.src"),
    "measure": ("measure", "--plan", "plan.csv", "-o", "again.parquet", "-q"),
    "check": ("check", "--calibration", "cal.json", "-o", "check.json", "--poses", "6", "-q"),
    "verify": ("verify", "--calibration", "cal.json", "-o", "v.json", "--cycles", "2", "-q"),
    "report": ("report", "cal.json", "session.parquet", "-o", "report"),
    "export-params": ("export-params", "cal.json", "-o", "params.yaml"),
}
#: The file each command takes its arm from.
SOURCE = {
    "program": "plan.csv",
    "measure": "plan.csv",
    "check": "cal.json",
    "verify": "cal.json",
    "report": "cal.json",
    "export-params": "cal.json",
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_conflicting_model_is_refused_naming_both_and_the_file(kuka, command):
    before = listing(kuka)
    line = one_line_error(cli(*COMMANDS[command], "--model", "ur10e", cwd=kuka))
    assert f"--model ur10e but {SOURCE[command]} is of a {ARM}" in line
    assert listing(kuka) == before


def test_the_same_model_given_again_is_no_conflict(kuka, tmp_path):
    done = cli("program", kuka / "plan.csv", "-o", tmp_path / "p.src", "--model", "KUKA-KR6-R900",
               cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr


def test_program_and_measure_take_the_plans_arm(kuka, tmp_path):
    done = cli("program", kuka / "plan.csv", "-o", tmp_path / "cell.src", cwd=tmp_path)
    assert done.code == 0, done.stderr
    text = (tmp_path / "cell.src").read_text()
    assert f"calibration of a {ARM}" in text and "A1 " in text
    done = cli("measure", "--plan", kuka / "plan.csv", "-o", tmp_path / "s.parquet", "-q",
               cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    assert session.load(tmp_path / "s.parquet").meta.model == ARM


def test_check_and_verify_take_the_calibrations_arm(kuka, tmp_path):
    cal = kuka / "cal.json"
    done = cli("check", "--calibration", cal, "-o", tmp_path / "c.json", "--poses", "6", "-q",
               cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr  # verdict ok: the KUKA as calibrated
    doc = json.loads((tmp_path / "c.json").read_text())
    assert doc["model"] == ARM and doc["verdict"] == "ok"
    done = cli("verify", "--calibration", cal, "-o", tmp_path / "v.json", "--cycles", "2", "-q",
               cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    doc = json.loads((tmp_path / "v.json").read_text())
    assert doc["model"] == ARM
    assert max(p["AP_mm"] for p in doc["poses"]) < 0.5  # compensated on the KUKA


def test_report_and_export_take_the_calibrations_arm(kuka, tmp_path):
    done = cli("report", kuka / "cal.json", kuka / "session.parquet", "-o", tmp_path / "r",
               cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    assert f"Calibration of {ARM}" in (tmp_path / "r" / "index.html").read_text()
    done = cli("export-params", kuka / "cal.json", "-o", tmp_path / "k.yaml", cwd=tmp_path)
    assert done.code == 0, done.stderr
    keys = list(yaml.safe_load((tmp_path / "k.yaml").read_text())["kinematics"])
    assert keys == [f"joint_a{i}" for i in range(1, 7)] + ["hash"]


def test_model_names_the_arm_of_a_calibration_that_names_none(kuka, tmp_path):
    doc = json.loads((kuka / "cal.json").read_text())
    del doc["model"]  # a calibration of a session's own table
    (tmp_path / "anon.json").write_text(json.dumps(doc))
    done = cli("export-params", "anon.json", "-o", "plain.urdf", cwd=tmp_path)
    assert done.code == 0, done.stderr
    names = [j.get("name") for j in ET.parse(tmp_path / "plain.urdf").getroot().iter("joint")]
    assert "shoulder_pan_joint" in names  # nothing says it is a KUKA
    done = cli("export-params", "anon.json", "-o", "kuka.urdf", "--model", ARM, cwd=tmp_path)
    assert done.code == 0, done.stderr
    names = [j.get("name") for j in ET.parse(tmp_path / "kuka.urdf").getroot().iter("joint")]
    assert names[:6] == [f"joint_a{i}" for i in range(1, 7)]
    # An arm whose table is not the calibration's is refused.
    line = one_line_error(cli("export-params", "anon.json", "--model", "ur10e", cwd=tmp_path))
    assert "anon.json" in line and "not a ur10e" in line


def test_export_like_of_the_shipped_urdf_needs_no_link_options(kuka, tmp_path):
    own = shipped.DATA / f"{ARM}.urdf"
    done = cli("export-params", kuka / "cal.json", "--format", "urdf", "--like", own,
               "-o", tmp_path / "like.urdf", cwd=tmp_path)  # fmt: skip
    assert done.code == 0, done.stderr
    # Read back along the description's chain (base_link to flange): the calibrated table.
    cal = calibration.load(kuka / "cal.json")
    chain = robot_urdf.read_chain(tmp_path / "like.urdf", "base_link", "flange")
    np.testing.assert_allclose(robot_urdf.kinematics_of(chain).mdh, cal.mdh, rtol=0, atol=1e-6)
    # Everything but the joint origins is the shipped file's.
    kept = ET.parse(own).getroot()
    written = ET.parse(tmp_path / "like.urdf").getroot()
    assert [j.get("name") for j in written.iter("joint")] == [
        j.get("name") for j in kept.iter("joint")
    ]
    assert [ET.tostring(j.find("axis")) for j in written.iter("joint") if j.find("axis")] == [
        ET.tostring(j.find("axis")) for j in kept.iter("joint") if j.find("axis")
    ]
