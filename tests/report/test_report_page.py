"""The report page, parsed: the right numbers in the right cells of the right section."""

import base64
from html.parser import HTMLParser

import numpy as np
import pytest
import report_kit

from calibrator.report import data, page


class Parsed(HTMLParser):
    """Per section: heading, table rows (cell texts), paragraphs (class, text), images.

    Text outside any of those (stray characters between elements) fails the parse.
    """

    def __init__(self, text):
        super().__init__(convert_charrefs=True)
        self.head = {"title": "", "h1": "", "lang": None, "charset": None}
        self.sections, self.order, stray = {}, [], []
        self._section = self._cell = self._para = self._in = None
        self._stray = stray
        self.feed(text)
        self.close()
        assert stray == [], stray

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "html":
            self.head["lang"] = attrs.get("lang")
        elif tag == "meta":
            self.head["charset"] = attrs.get("charset")
        elif tag in ("title", "h1", "h2", "style"):
            self._in = tag
        elif tag == "section":
            self._section = {"h2": "", "rows": [], "paras": [], "images": [], "spans": []}
            self.sections[attrs["id"]] = self._section
            self.order.append(attrs["id"])
        elif tag == "tr":
            self._section["rows"].append([])
        elif tag in ("td", "th"):
            self._cell = [""]
            self._section["rows"][-1].append(self._cell)
            self._section["spans"].append(attrs.get("colspan"))
        elif tag == "p":
            self._para = [attrs.get("class"), ""]
            self._section["paras"].append(self._para)
        elif tag == "img":
            self._section["images"].append((attrs["src"], attrs["alt"]))

    def handle_endtag(self, tag):
        if tag in ("title", "h1", "h2", "style"):
            self._in = None
        elif tag in ("td", "th"):
            self._cell = None
        elif tag == "p":
            self._para = None

    def handle_data(self, text):
        if self._in in ("title", "h1"):
            self.head[self._in] += text
        elif self._in == "h2":
            self._section["h2"] += text
        elif self._cell is not None:
            self._cell[0] += text
        elif self._para is not None:
            self._para[1] += text
        elif self._in != "style" and text.strip():
            self._stray.append(text)

    def rows(self, section):
        return [[c[0] for c in row] for row in self.sections[section]["rows"]]

    def paras(self, section):
        return [tuple(p) for p in self.sections[section]["paras"]]


def stat(n, mean, std, peak, orientation=None):
    entry = {"n": n, "position_mm": {"mean": mean, "std": std, "max": peak}}
    if orientation is not None:
        entry["orientation_deg"] = orientation
    return entry


def content(**fields):
    return report_kit.content(
        **{
            "title": "Calibration of <UR10e> & co",
            "facts": [("calibration", "cal <1>.json"), ("seed", 7), ("k", 2e4)],
            **fields,
        }
    )


IMAGES = {
    "pose_errors.png": b"P1",
    "error_cdf.png": b"C2",
    "error_vs_distance.png": b"D3",
    "convergence.png": b"G4",
    "deltas.png": b"B5",
}


def src(png):
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def test_head_summary_and_warnings_are_escaped_text():
    text = page.html(content(warnings=["poses 3 & 4 <same>"]), {})
    assert text.startswith("<!DOCTYPE html>\n") and text.endswith("</body></html>\n")
    parsed = Parsed(text)
    assert parsed.head == {
        "title": "Calibration of <UR10e> & co",
        "h1": "Calibration of <UR10e> & co",
        "lang": "en",
        "charset": "utf-8",
    }
    assert "<UR10e>" not in text  # escaped, not markup
    assert parsed.order == [
        "summary",
        "accuracy",
        "pose_errors",
        "error_cdf",
        "error_vs_distance",
        "convergence",
        "deltas",
        "dropped",
    ]
    assert {k: parsed.sections[k]["h2"] for k in parsed.order} == {
        "summary": "Summary",
        "accuracy": "Accuracy",
        "pose_errors": "Error per pose",
        "error_cdf": "Error distribution",
        "error_vs_distance": "Error against distance",
        "convergence": "Swarm convergence",
        "deltas": "Identified parameters",
        "dropped": "Parameters not identified",
    }
    assert parsed.rows("summary") == [
        ["calibration", "cal <1>.json"],
        ["seed", "7"],
        ["k", "20000.0"],
    ]
    assert parsed.paras("summary") == [("warning", "warning: poses 3 & 4 <same>")]
    assert "<script" not in text and "http" not in text


def test_accuracy_table_rows_hold_the_statistics_of_their_set_and_model():
    orientation_before = {
        a: {"mean": m, "std": m / 2, "max": 2 * m} for a, m in zip("xyz", (1, 2, 3), strict=True)
    }
    orientation_after = {
        a: {"mean": m, "std": m / 4, "max": 3 * m}
        for a, m in zip("xyz", (0.1, 0.2, 0.3), strict=True)
    }
    stats = {
        "fit": {
            "before": stat(20, 1.23456, 0.5, 3.0, orientation_before),
            "after": stat(20, 0.012345, 0.00555, 0.04, orientation_after),
        },
        "validation": {"before": stat(5, 2.0, 0.25, 2.5), "after": stat(5, 0.02, 0.01, 0.03)},
    }
    rows = Parsed(page.html(content(stats=stats), {})).rows("accuracy")
    assert rows == [
        ["", "poses", "mean", "std", "max"],
        ["fitted: position (mm), nominal", "20", "1.2346", "0.5000", "3.0000"],
        ["fitted: position (mm), identified", "20", "0.0123", "0.0056", "0.0400"],
        ["fitted: orientation X (deg), nominal", "20", "1.0000", "0.5000", "2.0000"],
        ["fitted: orientation X (deg), identified", "20", "0.1000", "0.0250", "0.3000"],
        ["fitted: orientation Y (deg), nominal", "20", "2.0000", "1.0000", "4.0000"],
        ["fitted: orientation Y (deg), identified", "20", "0.2000", "0.0500", "0.6000"],
        ["fitted: orientation Z (deg), nominal", "20", "3.0000", "1.5000", "6.0000"],
        ["fitted: orientation Z (deg), identified", "20", "0.3000", "0.0750", "0.9000"],
        ["held-out: position (mm), nominal", "5", "2.0000", "0.2500", "2.5000"],
        ["held-out: position (mm), identified", "5", "0.0200", "0.0100", "0.0300"],
    ]


@pytest.mark.parametrize(
    "validation",
    [None, {}, {"before": None, "after": None}, {"before": {"n": 0}, "after": {"n": 0}}],
)
def test_a_set_without_poses_is_one_row_saying_none(validation):
    stats = {"fit": {"before": stat(3, 1.0, 0.0, 1.0), "after": stat(3, 0.5, 0.0, 0.5)}}
    if validation is not None:
        stats["validation"] = validation
    parsed = Parsed(page.html(content(stats=stats), {}))
    assert parsed.rows("accuracy")[-1] == ["held-out poses", "0", "none"]
    assert parsed.sections["accuracy"]["spans"][-1] == "3"
    assert len(parsed.rows("accuracy")) == 4
    empty = Parsed(page.html(content(stats={}), {}))
    assert empty.rows("accuracy")[1:] == [
        ["fitted poses", "0", "none"],
        ["held-out poses", "0", "none"],
    ]


def test_every_plot_section_embeds_its_own_image():
    poses = data.PoseErrors(*(np.zeros(1),) * 5, origin="tracker")
    parsed = Parsed(page.html(content(poses=poses, deltas={"a1": 0.1}), IMAGES))
    titles = {
        "pose_errors": ("Error per pose", "pose_errors.png"),
        "error_cdf": ("Error distribution", "error_cdf.png"),
        "error_vs_distance": ("Error against distance", "error_vs_distance.png"),
        "convergence": ("Swarm convergence", "convergence.png"),
    }
    for key, (title, name) in titles.items():
        section = parsed.sections[key]
        assert section["h2"] == title
        assert section["images"] == [(src(IMAGES[name]), title)]
        assert section["paras"] == []  # no note: tracker frame, image present
    deltas = parsed.sections["deltas"]
    assert deltas["h2"] == "Identified parameters"
    assert deltas["images"] == [(src(IMAGES["deltas.png"]), "Identified deltas")]


def test_missing_images_say_why():
    notes = {"pose_errors": "give the session <file>", "convergence": "not recorded"}
    parsed = Parsed(page.html(content(notes=notes), {}))
    assert parsed.paras("pose_errors") == [("note", "give the session <file>")]
    assert parsed.paras("convergence") == [("note", "not recorded")]
    assert parsed.paras("error_cdf") == [("note", "not available")]
    assert parsed.paras("deltas") == [
        ("note", "standard errors: not recorded"),
        ("note", "no free parameters"),
    ]
    assert all(parsed.sections[k]["images"] == [] for k in parsed.order)
    assert parsed.rows("deltas") == []


def test_robot_base_distances_are_explained_only_for_a_base_frame_session():
    def distance_notes(origin):
        poses = data.PoseErrors(*(np.zeros(1),) * 5, origin=origin)
        return Parsed(page.html(content(poses=poses), IMAGES)).paras("error_vs_distance")

    assert distance_notes("tracker") == []
    assert distance_notes("robot base") == [
        (
            "note",
            "The session is in the robot base frame, where the tracker's position is not "
            "recorded: distances are from the robot base.",
        )
    ]
    assert Parsed(page.html(content(), IMAGES)).paras("error_vs_distance") == []


def test_deltas_table_values_standard_errors_and_units():
    deltas = {"a1": 0.123456789, "theta2": -0.00123456789, "tool_x": 2.5, "tool_rz": 1e-7}
    errors = {"a1": 0.0123456, "theta2": 4.5678e-5, "tool_rz": 2e-8}
    records = [
        {"name": "a1", "nominal": 0.0, "identified": 0.123456789},
        {"name": "theta2", "nominal": 1.5, "identified": 1.5 - 0.00123456789},
    ]
    shown = content(deltas=deltas, standard_errors=errors, parameters=records)
    parsed = Parsed(page.html(shown, IMAGES))
    # Angles in degrees, lengths in mm; every number of one unit to the decimals of two
    # digits of that unit's smallest standard error (mm: 0.0123 -> 3; deg: 2e-8 rad is
    # 1.15e-6 deg -> 7), so columns read down evenly; nominal and identified beside the delta.
    assert parsed.rows("deltas") == [
        ["parameter", "unit", "nominal", "identified", "delta", "standard error"],
        ["a1", "mm", "0.000", "0.123", "0.123", "0.012"],
        ["theta2", "deg", "85.9436693", "85.8729337", "-0.0707355", "0.0026172"],
        ["tool_x", "mm", "", "", "2.500", "not recorded"],
        ["tool_rz", "deg", "", "", "0.0000057", "0.0000011"],
    ]
    assert len(parsed.paras("deltas")) == 1  # the units note; standard errors were recorded
    bare = Parsed(page.html(content(deltas={"d4": 0.5}), IMAGES))
    assert bare.rows("deltas")[1] == ["d4", "mm", "", "", "0.5000", "not recorded"]


def test_dropped_parameters_with_their_reasons_or_none():
    dropped = [
        {"name": "d1", "reason": "same effect as <base_z>"},
        {"name": "tool_z", "reason": "no effect"},
        {"name": "<link 7>", "reason": "from an older & other model"},
    ]
    text = page.html(content(dropped=dropped), {})
    assert "<link 7>" not in text and "older & other" not in text  # escaped
    parsed = Parsed(text)
    assert parsed.sections["dropped"]["h2"] == "Parameters not identified"
    assert parsed.rows("dropped") == [
        ["parameter", "reason"],
        ["d1", "same effect as <base_z>"],
        ["tool_z", "no effect"],
        ["<link 7>", "from an older & other model"],
    ]
    assert parsed.paras("dropped") == []
    none = Parsed(page.html(content(), {}))
    assert none.rows("dropped") == [] and none.paras("dropped") == [("note", "none")]
