"""The calibration report: files, HTML structure and faithful numbers (no pixel checks)."""

import base64
import copy
import json
from html.parser import HTMLParser

import numpy as np
import pytest
from cli_kit import cli, listing, one_line_error

from calibrator import calibration, report, session
from calibrator.identify import pipeline
from calibrator.report import data
from calibrator.simulate import simulate

PLOTS = ("pose_errors", "error_cdf", "error_vs_distance", "convergence", "deltas")


class Page(HTMLParser):
    """Sections (by id), their images and text, and every outside reference."""

    def __init__(self, text):
        super().__init__()
        self.sections, self.outside, self._current = {}, [], None
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "section":
            self._current = attrs["id"]
            self.sections[self._current] = {"images": [], "text": ""}
        for key in ("src", "href"):
            if key in attrs:
                if attrs[key].startswith("data:image/png;base64,"):
                    self.sections[self._current]["images"].append(attrs[key].split(",", 1)[1])
                else:
                    self.outside.append(attrs[key])
        if tag in ("script", "link", "iframe"):
            self.outside.append(tag)

    def handle_data(self, text):
        if self._current:
            self.sections[self._current]["text"] += text + " "


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """A noisy tracker-frame session with an unknown tool, identified in-process."""
    folder = tmp_path_factory.mktemp("identified")
    table, meta, _ = simulate(
        model="ur10e",
        poses=30,
        seed=5,
        frame="tracker",
        noise_mm=0.02,
        tool_offset_mm=3.0,
        errors="random",
    )
    path = folder / "s.parquet"
    session.write(path, table, meta)
    loaded = session.load(path)
    result = pipeline.identify(loaded, pipeline.Options(generations=150))
    cal = calibration.Calibration.from_result(result, path, loaded.meta.model, loaded.meta.frame)
    doc = json.loads(json.dumps(cal.to_json()))
    return folder, doc, loaded


def test_report_renders_from_a_simulated_session(identified, tmp_path):
    _, doc, loaded = identified
    written = report.write(tmp_path / "rep", calibration.from_json(doc), loaded)
    names = sorted(p.name for p in written)
    assert names == sorted([f"{p}.png" for p in PLOTS] + ["index.html"])
    assert sorted(p.name for p in (tmp_path / "rep").iterdir()) == names  # nothing else left
    page = Page((tmp_path / "rep" / "index.html").read_text())
    assert page.outside == []  # self-contained: no scripts, links or outside images
    assert set(page.sections) == {"summary", "accuracy", "dropped", *PLOTS}
    for plot in PLOTS:
        png = (tmp_path / "rep" / f"{plot}.png").read_bytes()
        assert png.startswith(b"\x89PNG\r\n\x1a\n")
        assert page.sections[plot]["images"] == [base64.b64encode(png).decode()]
    dropped = page.sections["dropped"]["text"]
    assert all(d["name"] in dropped for d in doc["dropped_parameters"])
    deltas = page.sections["deltas"]["text"]
    assert all(name in deltas for name in doc["free_parameters"])
    # identify records standard errors (issue 9): the table shows them.
    assert "standard error" in deltas and "standard errors: not recorded" not in deltas
    assert "robot base" not in page.sections["error_vs_distance"]["text"]  # tracker frame
    assert "held-out" in page.sections["accuracy"]["text"]


def test_per_pose_errors_match_the_recorded_statistics(identified):
    _, doc, loaded = identified
    poses = data.pose_errors(calibration.from_json(doc), loaded)
    assert (
        poses.origin == "tracker"
        and poses.held_out.sum() == doc["stats"]["validation"]["before"]["n"]
    )
    for part, mask in (("fit", ~poses.held_out), ("validation", poses.held_out)):
        for when, values in (("before", poses.before_mm), ("after", poses.after_mm)):
            recorded = doc["stats"][part][when]["position_mm"]
            assert np.mean(values[mask]) == pytest.approx(recorded["mean"], rel=1e-9)
            assert np.max(values[mask]) == pytest.approx(recorded["max"], rel=1e-9)
    np.testing.assert_allclose(
        poses.distance_mm, np.linalg.norm(loaded.observations.points, axis=1)
    )


def test_standard_errors_and_convergence_when_recorded_and_not(identified, tmp_path):
    _, doc, _ = identified
    full = copy.deepcopy(doc)
    errors = {name: 0.001 * (i + 1) for i, name in enumerate(doc["deltas"])}
    full["uncertainty"] = {"standard_errors": errors}  # as issue 9 records them
    full["solver"]["convergence"] = [5.0, 2.0, 1.0]  # one cost per generation, older form
    full["warnings"] = ["poses 3 and 4 are the same pose"]
    content = data.collect(calibration.from_json(full))
    assert content.standard_errors == errors
    np.testing.assert_array_equal(content.convergence, [[0, 5.0], [1, 2.0], [2, 1.0]])
    text = report.page.html(content, report.plots.draw(content))
    page = Page(text)
    assert "not recorded" not in page.sections["deltas"]["text"]
    assert "warning: poses 3 and 4 are the same pose" in page.sections["summary"]["text"]
    assert page.sections["convergence"]["images"]
    # The largest standard error, to its unit's decimals (two digits of its smallest).
    last = list(doc["deltas"])[-1]
    rad = data.unit_of(last) == "rad"
    scale = np.degrees(1.0) if rad else 1.0
    same = [e for n, e in errors.items() if (data.unit_of(n) == "rad") == rad]
    decimals = 1 - int(np.floor(np.log10(min(same) * scale)))
    shown = f"{errors[last] * scale:.{decimals}f}"
    assert shown in page.sections["deltas"]["text"]
    for plot in ("pose_errors", "error_cdf", "error_vs_distance"):  # no session given
        assert page.sections[plot]["images"] == []
        assert "give the session file" in page.sections[plot]["text"]
    bare = copy.deepcopy(doc)
    bare["solver"].pop("convergence")
    page = Page(report.page.html(data.collect(calibration.from_json(bare)), {}))
    assert "not recorded" in page.sections["convergence"]["text"]


def test_report_command_and_a_session_that_does_not_match(identified, tmp_path):
    folder, doc, _ = identified
    (tmp_path / "c.json").write_text(json.dumps(doc))
    (tmp_path / "s.parquet").write_bytes((folder / "s.parquet").read_bytes())
    made = cli(
        "simulate",
        "-o",
        "other.parquet",
        "--poses",
        "12",
        "--model",
        "ur10e",
        "--frame",
        "tracker",
        cwd=tmp_path,
    )
    assert made.code == 0
    before = listing(tmp_path)
    line = one_line_error(cli("report", "c.json", "other.parquet", "-o", "rep", cwd=tmp_path))
    assert "other.parquet has 12 poses" in line
    assert listing(tmp_path) == before  # no report folder left behind
    done = cli("report", "c.json", "-o", "rep", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert sorted(p.name for p in (tmp_path / "rep").iterdir()) == [
        "convergence.png",
        "deltas.png",
        "index.html",
    ]


def test_identify_writes_the_report_with_the_calibration(tmp_path):
    assert cli("simulate", "-o", "s.parquet", "--poses", "20", cwd=tmp_path).code == 0
    run = cli("identify", "s.parquet", "--method", "lm", "-q", "--report", "rep", cwd=tmp_path)
    assert run.code == 0, run.stderr
    assert (tmp_path / "calibration.json").is_file()
    page = Page((tmp_path / "rep" / "index.html").read_text())
    assert page.sections["pose_errors"]["images"]  # the session was at hand
    assert "distances are from the robot base" in page.sections["error_vs_distance"]["text"]
    assert "not recorded" in page.sections["convergence"]["text"]  # lm runs no swarm


def test_a_minimal_or_malformed_calibration_file(identified, tmp_path):
    folder, doc, _ = identified
    keys = ("format", "version", "mdh", "nominal_mdh", "base2tracker", "flange2tool")
    keys += ("free_parameters", "deltas")
    minimal = {k: doc[k] for k in keys}
    (tmp_path / "min.json").write_text(json.dumps(minimal))
    no_tool = {k: v for k, v in minimal.items() if k != "flange2tool"}
    (tmp_path / "notool.json").write_text(json.dumps(no_tool))
    (tmp_path / "bad.json").write_text(json.dumps({**doc, "deltas": {"a1": "x"}}))
    (tmp_path / "s.parquet").write_bytes((folder / "s.parquet").read_bytes())
    before = listing(tmp_path)
    line = one_line_error(cli("report", "notool.json", "s.parquet", "-o", "rep", cwd=tmp_path))
    assert line.startswith("calibrator: error: notool.json: 'flange2tool' must be a 4x4 table")
    assert "bad.json: 'deltas' must map" in one_line_error(
        cli("report", "bad.json", "-o", "rep", cwd=tmp_path)
    )
    assert listing(tmp_path) == before
    done = cli("report", "min.json", "-o", "rep", cwd=tmp_path)
    assert done.code == 0 and "wrote 2 files into rep: deltas.png, index.html" in done.stdout
    page = Page((tmp_path / "rep" / "index.html").read_text())
    assert "none" in page.sections["dropped"]["text"]
    assert "not recorded" in page.sections["convergence"]["text"]
