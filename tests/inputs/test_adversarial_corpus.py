"""Adversarial inputs across every surface that reads a file or an option.

Each case builds one bad input beside good ones and runs the real command
line. Every case must end the same way: exit code 2, one line on stderr
naming what was wrong (no traceback), and the folder exactly as it was
(no input changed, no partial or temporary file, no report folder).

Surfaces: exports (X1); compensate, ``--nominal`` and report (X2); plans
and analyze (X3); old and corrupted sessions (I1).
"""

import json
import shutil

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from cli_kit import cli, listing, one_line_error

from calibrator import planning

HUGE_INT = "9" * 400  # above 1e308: math.isfinite raised OverflowError on it


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """Good inputs: UR10e and UR5e sessions, a calibration, a plan, UR and ROS files."""
    folder = tmp_path_factory.mktemp("base")

    def run(*args):
        done = cli(*args, cwd=folder)
        assert done.code == 0, done.stderr

    run("simulate", "--model", "ur10e", "--poses", "40", "-o", "s10.parquet")
    run("simulate", "--model", "ur5e", "--poses", "40", "-o", "s5.parquet")
    run("identify", "s10.parquet", "--method", "lm", "-q", "-o", "cal.json")
    run("plan", "--model", "ur10e", "--poses", "12", "-o", "plan.csv")
    run("export-params", "cal.json", "--format", "ur-calibration", "-o", "cal.urcal")
    run("export-params", "cal.json", "--format", "ros-kinematics", "-o", "kin.yaml")
    q = planning.read_plan(folder / "plan.csv").q_rad
    rows = ["q1_rad,q2_rad,q3_rad,q4_rad,q5_rad,q6_rad"] + [
        ",".join(repr(float(v)) for v in r) for r in q
    ]
    (folder / "targets.csv").write_text("\n".join(rows) + "\n")
    return folder


# ---------------------------------------------------------------- editors


def text_edit(name, old, new, count=1):
    def edit(folder):
        path = folder / name
        text = path.read_text()
        assert old in text, (name, old)
        path.write_text(text.replace(old, new, count))

    return edit


def json_edit(change):
    def edit(folder):
        doc = json.loads((folder / "cal.json").read_text())
        change(doc)
        (folder / "cal.json").write_text(json.dumps(doc, indent=2))

    return edit


def raw_json(transform):
    def edit(folder):
        path = folder / "cal.json"
        path.write_text(transform(path.read_text()))

    return edit


def plan_rows(transform):
    def edit(folder):
        lines = (folder / "plan.csv").read_text().splitlines()
        (folder / "plan.csv").write_text("\n".join(transform(lines)) + "\n")

    return edit


def session_edit(change_table=None, meta_text=None):
    """Rewrite s10.parquet with a changed table and/or raw metadata bytes."""

    def edit(folder):
        path = folder / "s10.parquet"
        table = pq.read_table(path)
        raw = table.schema.metadata[b"calibrator"]
        if change_table is not None:
            table = change_table(table)
        meta = dict(table.schema.metadata or {})
        meta[b"calibrator"] = raw if meta_text is None else meta_text(raw.decode()).encode()
        pq.write_table(table.replace_schema_metadata(meta), path)

    return edit


def huge_pose(table):
    poses = pa.array(np.arange(table.num_rows, dtype=np.uint64) + np.uint64(2**63 + 7))
    return table.set_column(table.column_names.index("pose"), "pose", poses)


def meta_json(change):
    def text(raw):
        doc = json.loads(raw)
        change(doc)
        return json.dumps(doc)

    return text


def add_deltas(doc, name, by):
    doc["deltas"][name] += by


def huge_nominal(doc):
    doc["nominal_mdh"] = [[1e308] * 5] * 6


def far_tool():
    return [[1, 0, 0, 1e300], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]


def make_index(folder):
    (folder / "rep").mkdir()
    (folder / "rep" / "index.html").write_text("<p>the user's own page</p>\n")


def nothing(folder):
    pass


UR5E = '"model": "ur5e"'
EXPORT = ("export-params", "cal.json", "--format", "ur-calibration", "-o", "out.urcal")
NOMINAL_UR = ("identify", "s10.parquet", "--method", "lm", "-q", "--nominal", "cal.urcal")
NOMINAL_ROS = ("identify", "s10.parquet", "--method", "lm", "-q", "--nominal", "kin.yaml")
COMPENSATE = ("compensate", "cal.json", "targets.csv", "-o", "out.csv")
PLAN_FROM = ("plan", "--from", "plan.csv", "-o", "new.csv", "--poses", "3")
MIS = ("analyze", "misalignment", "-q", "--trials", "100")
TOL = ("analyze", "tolerance", "--model", "ur10e", "--poses", "5", "--samples", "10")

CASES = {
    # X1: exports of a calibration that is not what it says.
    "x1-model-relabelled": (raw_json(lambda t: t.replace('"model": "ur10e"', UR5E)), EXPORT),
    "x1-duplicate-model-key": (
        raw_json(lambda t: t.replace('"model": "ur10e"', '"model": "ur10e", ' + UR5E)),
        EXPORT,
    ),
    "x1-huge-int-in-table": (
        raw_json(
            lambda t: t.replace(
                '"nominal_mdh": [\n    [\n      0.0',
                '"nominal_mdh": [\n    [\n      ' + HUGE_INT,
                1,
            )
        ),
        EXPORT,
    ),
    "x1-huge-int-in-diagnostics": (
        raw_json(lambda t: t.replace('"format":', f'"extra": {HUGE_INT}, "format":')),
        EXPORT,
    ),
    "x1-overflowing-float": (
        raw_json(lambda t: t.replace('"format":', '"extra": 1e400, "format":')),
        EXPORT,
    ),
    "x1-hand-edited-deltas": (json_edit(lambda d: add_deltas(d, "a2", 0.5)), EXPORT),
    "x1-huge-nominal-table": (json_edit(huge_nominal), EXPORT),
    "x1-urdf-of-a-relabelled-model": (
        raw_json(lambda t: t.replace('"model": "ur10e"', UR5E)),
        ("export-params", "cal.json", "--format", "urdf", "-o", "arm.urdf"),
    ),
    # X2: compensate, --nominal, report.
    "x2-compensate-relabelled": (
        raw_json(lambda t: t.replace('"model": "ur10e"', UR5E)),
        COMPENSATE,
    ),
    "x2-urcal-percent": (text_edit("cal.urcal", "model = ur10e", "model = ur10e%"), NOMINAL_UR),
    "x2-urcal-percent-in-deltas": (
        text_edit("cal.urcal", "delta_theta = [", "delta_theta = [%"),
        NOMINAL_UR,
    ),
    "x2-urcal-huge-int": (
        text_edit("cal.urcal", "delta_a = [", f"delta_a = [{HUGE_INT}, "),
        NOMINAL_UR,
    ),
    "x2-urcal-overflow": (text_edit("cal.urcal", "delta_d = [", "delta_d = [1e400, "), NOMINAL_UR),
    "x2-urcal-duplicate-option": (
        text_edit("cal.urcal", "[calibrator]", "[calibrator]\nmodel = ur5e"),
        NOMINAL_UR,
    ),
    "x2-yaml-duplicate-key": (
        text_edit("kin.yaml", "  shoulder:\n", "  shoulder:\n    x: 0.5\n"),
        NOMINAL_ROS,
    ),
    "x2-yaml-huge-int": (
        text_edit("kin.yaml", "    x: ", f"    x: {HUGE_INT}\n    y0: "),
        NOMINAL_ROS,
    ),
    "x2-yaml-hex": (text_edit("kin.yaml", "    x: ", "    x: 0x1F\n    y0: "), NOMINAL_ROS),
    "x2-yaml-underscore": (text_edit("kin.yaml", "    x: ", "    x: 0_5\n    y0: "), NOMINAL_ROS),
    "x2-report-over-another-arm": (nothing, ("report", "cal.json", "s5.parquet", "-o", "rep")),
    "x2-report-existing-index": (make_index, ("report", "cal.json", "s10.parquet", "-o", "rep")),
    "x2-identify-report-existing-index": (
        make_index,
        ("identify", "s10.parquet", "--method", "lm", "-q", "-o", "c2.json", "--report", "rep"),
    ),
    "x2-report-hand-edited-deltas": (
        json_edit(lambda d: add_deltas(d, "d4", -0.3)),
        ("report", "cal.json", "s10.parquet", "-o", "rep"),
    ),
    # X3: plans and analyze.
    "x3-plan-all-duplicates": (
        plan_rows(lambda x: [x[0]] + [x[1]] * 12),
        ("measure", "--plan", "plan.csv", "-o", "m.parquet", "-q"),
    ),
    "x3-plan-duplicates-from": (plan_rows(lambda x: [x[0]] + [x[1]] * 12), PLAN_FROM),
    "x3-plan-q7": (
        plan_rows(lambda x: [x[0] + ",q7_rad"] + [r + ",0.1" for r in x[1:]]),
        PLAN_FROM,
    ),
    "x3-plan-underscore": (
        plan_rows(lambda x: [x[0], "0," + "0_5," * 5 + "0_5"] + x[2:]),
        PLAN_FROM,
    ),
    "x3-plan-hex": (plan_rows(lambda x: [x[0], "0," + "0x1," * 5 + "0"] + x[2:]), PLAN_FROM),
    "x3-plan-poses": (nothing, ("plan", "--poses", str(10**9), "-o", "p.csv")),
    "x3-plan-candidates": (nothing, ("plan", "--candidates", str(10**9), "-o", "p.csv")),
    "x3-plan-default-candidates": (nothing, ("plan", "--poses", "1500", "-o", "p.csv")),
    "x3-plan-tool": (nothing, ("plan", "--tool", "0,0,1e308", "-o", "p.csv")),
    "x3-plan-tracker": (nothing, ("plan", "--tracker-at", "1e308,0,0", "-o", "p.csv")),
    "x3-option-underscore-float": (nothing, ("plan", "--margin-deg", "0_5", "-o", "p.csv")),
    "x3-option-underscore-int": (nothing, ("plan", "--poses", "1_0", "-o", "p.csv")),
    "x3-option-hex-int": (nothing, (*MIS, "--seed", "0x10")),
    "x3-option-nan": (nothing, (*TOL, "--joint-tol=nan")),
    "x3-simulate-poses": (nothing, ("simulate", "--poses", str(10**9), "-o", "x.parquet")),
    "x3-simulate-noise": (nothing, ("simulate", "--noise-mm", "1e308", "-o", "x.parquet")),
    "x3-simulate-tool": (nothing, ("simulate", "--tool-offset-mm", "1e308", "-o", "x.parquet")),
    "x3-identify-particles": (nothing, ("identify", "s10.parquet", "--particles", str(10**9))),
    "x3-identify-generations": (nothing, ("identify", "s10.parquet", "--generations", str(10**12))),
    "x3-identify-seed": (nothing, ("identify", "s10.parquet", "--seed", str(2**64))),
    "x3-mis-seed": (nothing, (*MIS, "--seed", "-1")),
    "x3-mis-trials": (nothing, ("analyze", "misalignment", "--trials", str(10**12))),
    "x3-mis-workers": (nothing, (*MIS, "--workers", "100000")),
    "x3-mis-chunk": (nothing, (*MIS, "--chunk", str(10**15))),
    "x3-mis-sweep-r0": (nothing, (*MIS, "--sweep-r0", "1e308")),
    "x3-mis-sweep-length": (nothing, (*MIS, "--sweep-length", "d3=1e308")),
    "x3-mis-sweep-many": (nothing, (*MIS, "--sweep-r0", ",".join(["0.01"] * 1000))),
    "x3-mis-r0": (nothing, (*MIS, "--r0", "1e308")),
    "x3-mis-h": (nothing, (*MIS, "--h", "1e-300")),
    "x3-mis-pose": (nothing, (*MIS, "--pose", "1e308,0,0,0,0,0")),
    "x3-mis-underscore": (nothing, (*MIS, "--r0", "0_5")),
    "x3-tol-length": (nothing, (*TOL, "--length-tol", "1e308")),
    "x3-tol-angle": (nothing, (*TOL, "--angle-tol", "1e308")),
    "x3-tol-override": (nothing, (*TOL, "--tol", "a2=1e308")),
    "x3-tol-seed": (nothing, (*TOL, "--seed", "-1")),
    "x3-tol-samples": (
        nothing,
        ("analyze", "tolerance", "--model", "ur10e", "--samples", str(10**12)),
    ),
    "x3-tol-poses-samples": (
        nothing,
        ("analyze", "tolerance", "--model", "ur10e", "--poses", "10000", "--samples", "10000"),
    ),
    # I1: sessions, old and corrupted.
    "i1-pose-uint64": (
        session_edit(change_table=huge_pose),
        ("identify", "s10.parquet", "-q", "--method", "lm"),
    ),
    "i1-nominal-1e308": (
        session_edit(meta_text=meta_json(huge_nominal)),
        ("identify", "s10.parquet", "-q", "--method", "lm"),
    ),
    "i1-meta-huge-int": (
        session_edit(meta_text=lambda t: t[:-1] + f', "x": {HUGE_INT}}}'),
        ("identify", "s10.parquet", "-q", "--method", "lm"),
    ),
    "i1-meta-duplicate-key": (
        session_edit(meta_text=lambda t: t[:-1] + ', "frame": "tracker"}'),
        ("identify", "s10.parquet", "-q", "--method", "lm"),
    ),
    "i1-spread-1e308": (
        session_edit(
            change_table=lambda t: t.append_column("sx_mm", pa.array([1e308] * t.num_rows))
        ),
        ("identify", "s10.parquet", "-q", "--method", "lm"),
    ),
    "i1-tool-1e300": (
        session_edit(meta_text=meta_json(lambda m: m.update(flange2tool=far_tool()))),
        ("identify", "s10.parquet", "-q", "--method", "lm"),
    ),
    "i1-meta-nan": (
        session_edit(meta_text=lambda t: t[:-1] + ', "x": NaN}'),
        ("report", "cal.json", "s10.parquet", "-o", "rep"),
    ),
}


def _targets_underscore(folder):
    lines = (folder / "targets.csv").read_text().splitlines()
    lines[2] = "0_5" + lines[2][lines[2].index(",") :]
    (folder / "targets.csv").write_text("\n".join(lines) + "\n")


CASES["x2-compensate-underscore"] = (_targets_underscore, COMPENSATE)


def _targets_long_row(folder):
    lines = (folder / "targets.csv").read_text().splitlines()
    lines[2] = "0," + lines[2]  # seven numbers under six names
    (folder / "targets.csv").write_text("\n".join(lines) + "\n")


CASES["x2-compensate-long-row"] = (_targets_long_row, COMPENSATE)


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_is_one_line_exit_2_and_changes_nothing(base, tmp_path, case):
    edit, args = CASES[case]
    work = tmp_path / "w"
    shutil.copytree(base, work)
    edit(work)
    before = listing(work)
    line = one_line_error(cli(*args, cwd=work))
    assert len(line) < 400, line
    assert listing(work) == before, case
