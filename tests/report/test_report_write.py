"""``report.write`` and ``calibrator report``: the files, the refusals, nothing left over."""

import json

import numpy as np
import pytest
from cli_kit import cli, listing, one_line_error
from report_kit import calibration_of

from calibrator import calibration, outputs, report, robots, session
from calibrator.simulate import simulate

NOMINAL = robots.get("ur10e").mdh


def document(a2_delta=0.0, **extra):
    mdh = NOMINAL.copy()
    mdh[1, 0] += a2_delta
    doc = {
        "format": calibration.FORMAT,
        "version": calibration.VERSION,
        "nominal_mdh": NOMINAL.tolist(),
        "mdh": calibration.mdh_records(mdh),
        "base2tracker": np.eye(4).tolist(),
        "flange2tool": np.eye(4).tolist(),
        "free_parameters": ["a2"] if a2_delta else [],
        "deltas": {"a2": a2_delta} if a2_delta else {},
    }
    doc.update(extra)
    return calibration.from_json(doc)


def test_write_returns_the_files_in_page_order_and_leaves_nothing_else(tmp_path):
    doc = document(0.5, solver={"convergence": [4.0, 2.0, 1.0]})
    written = report.write(str(tmp_path / "rep"), doc)
    assert written == [
        tmp_path / "rep" / n for n in ("convergence.png", "deltas.png", "index.html")
    ]
    files = listing(tmp_path)
    assert sorted(files) == ["rep", "rep/convergence.png", "rep/deltas.png", "rep/index.html"]
    page = files["rep/index.html"].decode()
    # Without standard errors lengths show 4 decimals (0.1 um), every column alike.
    nominal = f"{NOMINAL[1, 0]:.4f}"
    identified = f"{NOMINAL[1, 0] + 0.5:.4f}"
    assert (
        f"<td>a2</td><td>mm</td><td>{nominal}</td><td>{identified}</td>"
        "<td>0.5000</td><td>not recorded</td>"
    ) in page
    assert files["rep/deltas.png"].startswith(b"\x89PNG")


def test_an_input_inside_the_folder_is_refused_before_anything_is_read(tmp_path):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "index.html").write_text("my notes")
    before = listing(tmp_path)
    malformed = calibration_of({"convergence": [[0, 1, 2]]})  # would fail later, when gathered
    with pytest.raises(outputs.OutputError) as caught:
        report.write(rep, malformed, calibration_path=rep / "index.html")
    assert str(caught.value) == (
        f"refusing to overwrite {rep}/index.html: it is an input of this command; "
        "choose another output"
    )
    with pytest.raises(outputs.OutputError, match="index.html: it is an input"):
        report.write(rep, malformed, session_path=rep / "index.html")
    assert listing(tmp_path) == before


def test_a_failed_report_leaves_an_existing_folder_as_it_was(tmp_path):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "index.html").write_text("old page")
    (rep / "deltas.png").mkdir()  # a folder where the last image goes
    before = listing(tmp_path)
    doc = document(0.5, solver={"convergence": [4.0, 2.0]})
    with pytest.raises(outputs.OutputError, match="deltas.png: it is a folder"):
        report.write(rep, doc)
    assert listing(tmp_path) == before  # no temporary convergence.png left


def test_inside_a_batch_the_report_appears_with_the_batch(tmp_path):
    (tmp_path / "cal.json").write_text("{}")
    batch = outputs.Outputs(inputs=[tmp_path / "cal.json"])
    written = report.write(tmp_path / "rep", document(0.5), batch=batch)
    assert [p.name for p in written] == ["deltas.png", "index.html"]
    assert not (tmp_path / "rep" / "index.html").exists()  # the caller commits
    batch.commit()
    assert sorted(listing(tmp_path / "rep")) == ["deltas.png", "index.html"]
    # The batch's own inputs are what a report may not overwrite.
    other = outputs.Outputs(inputs=[tmp_path / "rep" / "index.html"])
    with pytest.raises(outputs.OutputError, match="it is an input"):
        report.write(tmp_path / "rep", document(0.5), batch=other, force=True)
    other.discard()


def _disk_full_at_the_page(monkeypatch):
    def text(self, path, text):
        raise outputs.OutputError(f"cannot write {path}: No space left on device")

    monkeypatch.setattr(outputs.Outputs, "text", text)


def test_a_report_failing_at_its_last_file_leaves_nothing(tmp_path, monkeypatch):
    _disk_full_at_the_page(monkeypatch)
    doc = document(0.5, solver={"convergence": [4.0, 2.0]})
    with pytest.raises(outputs.OutputError, match="index.html: No space"):
        report.write(tmp_path / "rep", doc)
    assert listing(tmp_path) == {}  # neither the new folder nor the images' temporary files


def test_a_failing_batch_report_is_left_for_the_caller_to_discard(tmp_path, monkeypatch):
    _disk_full_at_the_page(monkeypatch)
    batch = outputs.Outputs()
    with pytest.raises(outputs.OutputError, match="index.html: No space"):
        report.write(tmp_path / "rep", document(0.5), batch=batch)
    assert [t.name for _, t, _ in batch._pending] == ["deltas.png"]  # not discarded here
    batch.discard()
    assert listing(tmp_path) == {}


def test_report_command_counts_and_names_what_it_wrote(tmp_path):
    (tmp_path / "bare.json").write_text(json.dumps(document().to_json()))
    (tmp_path / "one.json").write_text(json.dumps(document(0.25).to_json()))
    done = cli("report", "bare.json", cwd=tmp_path)
    assert (done.code, done.stderr) == (0, "")
    assert done.stdout == "wrote 1 file into report: index.html\n"
    done = cli("report", "one.json", "-o", "rep2", cwd=tmp_path)
    assert done.stdout == "wrote 2 files into rep2: deltas.png, index.html\n"
    assert sorted(listing(tmp_path / "rep2")) == ["deltas.png", "index.html"]


def test_report_command_with_its_session(tmp_path):
    table, meta, truth = simulate(model="ur10e", poses=8, seed=2, frame="base", errors="none")
    session.write(tmp_path / "s.parquet", table, meta)
    doc = document(model="ur10e", validation_poses=[3])
    (tmp_path / "c.json").write_text(json.dumps(doc.to_json()))
    done = cli("report", "c.json", "s.parquet", "--output", "rep", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert done.stdout == (
        "wrote 4 files into rep: pose_errors.png, error_cdf.png, error_vs_distance.png, "
        "index.html\n"
    )
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "<tr><th>session</th><td>s.parquet</td></tr>" in page
    assert "<tr><th>calibration</th><td>c.json</td></tr>" in page


def test_report_command_refuses_bad_folders_in_one_line(tmp_path):
    (tmp_path / "c.json").write_text(json.dumps(document().to_json()))
    before = listing(tmp_path)
    line = one_line_error(cli("report", "c.json", "-o", "c.json", cwd=tmp_path))
    assert line == "calibrator: error: cannot write into c.json: it exists and is not a folder"
    line = one_line_error(cli("report", "c.json", "-o", "no/rep", cwd=tmp_path))
    assert line == "calibrator: error: cannot write no/rep: folder no does not exist"
    line = one_line_error(cli("report", "missing.json", "-o", "rep", cwd=tmp_path))
    assert line == "calibrator: error: calibration file not found: missing.json"
    assert listing(tmp_path) == before
