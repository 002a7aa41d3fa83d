"""What a calibration records: its session, every option that changes it, and its fit.

Run as a user runs them (real processes): the provenance in calibration.json,
``identify --like`` reproducing the parameters bit for bit, and the outliers
of a robust fit reaching the report.
"""

import hashlib
import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_kit import refused_line
from cli_process_kit import run_cli  # the CLI as a user runs it: a real process

from calibrator.identify import pipeline

#: Options that differ from every default, so a re-run that ignored one shows.
OPTIONS = (
    "--loss",
    "huber",
    "--seed",
    "3",
    "--validation-fraction",
    "0.25",
    "--noise-mm",
    "0.03",
    "--generations",
    "150",
    "--particles",
    "12",
    "--orientation-weight",
    "2500",
    "--tool-known",
)


@pytest.fixture(scope="module")
def outlier_session(tmp_path_factory):
    """A 30-pose simulated session whose fitted pose 6 was reseated 2 mm off."""
    folder = tmp_path_factory.mktemp("provenance")
    sim = run_cli("simulate", "-o", "s.parquet", "--poses", "30", cwd=folder)
    assert sim.returncode == 0, sim.stderr
    table = pq.read_table(folder / "s.parquet")
    fit_idx, _ = pipeline.split(30, 0.25, 3)
    row = int(fit_idx[6])
    x = table["x_mm"].to_numpy().copy()
    x[row] += 2.0
    table = table.set_column(table.schema.get_field_index("x_mm"), "x_mm", pa.array(x))
    pq.write_table(table, folder / "s.parquet")  # keeps the footer's session metadata
    pose = table["pose"].to_pylist()[row]
    ident = run_cli(
        "identify", "s.parquet", "-o", "c.json", "--report", "rep", *OPTIONS, cwd=folder
    )
    assert ident.returncode == 0, ident.stderr
    return folder, pose


def test_calibration_json_records_the_session_digest_and_every_option(outlier_session):
    folder, _ = outlier_session
    doc = json.loads((folder / "c.json").read_text())
    digest = hashlib.sha256((folder / "s.parquet").read_bytes()).hexdigest()
    assert doc["session_sha256"] == digest
    recorded = {
        key: doc[key]
        for key in (
            "loss",
            "method",
            "seed",
            "validation_fraction",
            "noise_mm",
            "tool_known",
            "k",
            "generations",
            "particles",
        )
    }
    assert recorded == {
        "loss": "huber",
        "method": "hybrid",
        "seed": 3,
        "validation_fraction": 0.25,
        "noise_mm": 0.03,
        "tool_known": True,
        "k": 2500.0,
        "generations": 150,
        "particles": 12,
    }
    assert set(doc["versions"]) == {"calibrator", "numpy", "scipy", "python"}
    assert doc["nominal_source"] == "session" and "nominal_file" not in doc


def test_a_huber_fit_shows_its_outlier_poses_in_the_report(outlier_session):
    folder, pose = outlier_session
    doc = json.loads((folder / "c.json").read_text())
    assert doc["outliers"] == [pose]
    page = (folder / "rep" / "index.html").read_text()
    summary = page[page.index('<section id="summary">') : page.index('<section id="accuracy">')]
    assert f"<tr><th>outlier poses set aside</th><td>{pose}</td></tr>" in summary
    # The report command reads the same file the same way.
    again = run_cli("report", "c.json", "s.parquet", "-o", "rep2", cwd=folder)
    assert again.returncode == 0, again.stderr
    assert f"<td>{pose}</td>" in (folder / "rep2" / "index.html").read_text()


def test_identify_like_reproduces_the_parameters_bit_for_bit(outlier_session):
    folder, _ = outlier_session
    like = run_cli("identify", "s.parquet", "-o", "again.json", "--like", "c.json", cwd=folder)
    assert like.returncode == 0, like.stderr
    first = json.loads((folder / "c.json").read_text())
    again = json.loads((folder / "again.json").read_text())
    assert again["deltas"] == first["deltas"]  # JSON floats: every bit
    assert again["mdh"] == first["mdh"] and again["base2tracker"] == first["base2tracker"]
    assert again["flange2tool"] == first["flange2tool"]
    for key in ("loss", "seed", "validation_fraction", "noise_mm", "tool_known", "k"):
        assert again[key] == first[key], key
    # Given options win over the recorded ones.
    other = run_cli(
        "identify", "s.parquet", "-o", "other.json", "--like", "c.json", "--seed", "4", cwd=folder
    )
    assert other.returncode == 0, other.stderr
    other_doc = json.loads((folder / "other.json").read_text())
    assert other_doc["seed"] == 4 and other_doc["loss"] == "huber"
    assert not np.array_equal(
        np.array(list(other_doc["deltas"].values())), np.array(list(first["deltas"].values()))
    )


def test_like_with_a_calibration_that_records_no_options_is_one_line(outlier_session, tmp_path):
    folder, _ = outlier_session
    doc = json.loads((folder / "c.json").read_text())
    for key in ("method", "loss", "seed", "validation_fraction", "k", "noise_mm", "tool_known"):
        doc.pop(key)
    for key in ("particles", "generations", "swarm_poses"):
        doc.pop(key)
    (tmp_path / "old.json").write_text(json.dumps(doc))
    (tmp_path / "s.parquet").write_bytes((folder / "s.parquet").read_bytes())
    out = run_cli("identify", "s.parquet", "-o", "n.json", "--like", "old.json", cwd=tmp_path)
    assert refused_line(out).endswith(
        "--like old.json: the file records no options (written before they were recorded)"
    )
    assert not (tmp_path / "n.json").exists()


def test_like_with_an_older_file_says_which_options_it_does_not_record(outlier_session, tmp_path):
    folder, _ = outlier_session
    doc = json.loads((folder / "c.json").read_text())
    for key in ("noise_mm", "tool_known", "particles", "generations", "swarm_poses"):
        doc.pop(key)  # what files written before provenance lack
    (tmp_path / "old.json").write_text(json.dumps(doc))
    (tmp_path / "s.parquet").write_bytes((folder / "s.parquet").read_bytes())
    out = run_cli("identify", "s.parquet", "-o", "n.json", "--like", "old.json", "-q", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert (
        "note: old.json does not record noise_mm, tool_known, particles, generations, "
        "swarm_poses: those take the values given here (or their defaults)"
    ) in out.stderr
    again = json.loads((tmp_path / "n.json").read_text())
    assert (again["loss"], again["seed"], again["noise_mm"]) == ("huber", 3, 0.05)
