"""The joint-term options and fitted joint ranges in calibration.json's typed parts."""

import json

import numpy as np
import pytest
from cli_kit import cli
from joint_kit import sessions

from calibrator import calibration, session
from calibrator.errors import CalibrationError
from calibrator.model import joint_terms

WRIST = joint_terms.JointTerms(
    np.array([0, 0, 0, 1e-3, 2e-3, -1.5e-3]), np.zeros(6), np.zeros(6), np.zeros(6)
)


def _write(folder, poses=40, seed=3):
    (part,), _ = sessions(WRIST, poses=poses, seed=seed)
    session.write(folder / "s.parquet", part[0].table, part[0].meta)


def test_identify_like_reuses_the_joint_term_options_and_reproduces_the_terms(tmp_path):
    _write(tmp_path)
    first = cli(
        "identify", "s.parquet", "--joint-terms", "scale", "--method", "lm",
        "--noise-mm", "0.02", "--payload-com-mm", "0,0,80", "-o", "a.json", cwd=tmp_path,
    )  # fmt: skip
    assert first.code == 0, first.stderr
    a = json.loads((tmp_path / "a.json").read_text())
    assert a["joint_term_groups"] == "scale"
    assert a["payload_com_mm"] == [0.0, 0.0, 80.0]
    assert "mass_model" not in a and "payload_kg" not in a  # not given: not recorded
    assert np.shape(a["fitted_joint_ranges_rad"]) == (6, 2)
    again = cli("identify", "s.parquet", "--like", "a.json", "-o", "b.json", cwd=tmp_path)
    assert again.code == 0, again.stderr
    b = json.loads((tmp_path / "b.json").read_text())
    assert b["joint_terms"] == a["joint_terms"]  # bit for bit
    assert b["deltas"] == a["deltas"]
    assert b["joint_term_groups"] == "scale" and b["payload_com_mm"] == [0.0, 0.0, 80.0]
    # An option given on the command line wins over the recorded one.
    plain = cli(
        "identify", "s.parquet", "--like", "a.json", "--joint-terms", "harmonic",
        "-o", "c.json", cwd=tmp_path,
    )  # fmt: skip
    assert plain.code == 0, plain.stderr
    assert json.loads((tmp_path / "c.json").read_text())["joint_term_groups"] == "harmonic"


def test_a_default_identify_records_no_joint_terms_requested(tmp_path):
    _write(tmp_path, poses=30)
    assert cli("identify", "s.parquet", "--method", "lm", "-o", "a.json", cwd=tmp_path).code == 0
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["joint_term_groups"] == "" and "joint_terms" not in doc
    back = calibration.load(tmp_path / "a.json")
    assert back.provenance.joint is not None and back.provenance.joint.joint_term_groups == ()
    assert back.provenance.recorded()["joint_term_groups"] == ""
    assert np.shape(back.fit.fitted_joint_ranges_rad) == (6, 2)


def _doc(tmp_path):
    _write(tmp_path, poses=30)
    assert cli("identify", "s.parquet", "--method", "lm", "-o", "a.json", cwd=tmp_path).code == 0
    return json.loads((tmp_path / "a.json").read_text())


@pytest.mark.parametrize(
    ("key", "value", "words"),
    [
        ("payload_com_mm", [0, 0], "three numbers"),
        ("payload_com_mm", "0,0,80", "must be a JSON array"),
        ("payload_kg", "5", "must be a JSON number"),
        ("joint_term_groups", ["scale"], "must be a JSON string"),
        ("fitted_joint_ranges_rad", [[0, 1]] * 5, "six [min, max] pairs"),
        ("fitted_joint_ranges_rad", [[0, "1"]] * 6, "six [min, max] pairs"),
    ],
)
def test_a_badly_typed_joint_option_or_range_is_named(tmp_path, key, value, words):
    doc = _doc(tmp_path)
    doc[key] = value
    with pytest.raises(CalibrationError) as err:
        calibration.from_json(doc, "bad.json")
    text = str(err.value)
    assert text.startswith("bad.json: ") and f"'{key}'" in text and words in text
