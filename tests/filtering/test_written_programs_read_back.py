"""The programs ``calibrator program`` writes, read back by the filter's own readers.

A measurement program written in a language the filter reads must read
back as exactly its moves: the home pose, every plan pose in order with the
vias before it, and nothing lost at either end; each pose's wait (with the
digital-output pulse where asked) adds up to the spec's dwell. A URScript
program of Cartesian targets (the nominal flange poses) is the filter's
round trip proper: written, filtered with a calibration, and sent to a
nominal controller, it puts the true arm where the nominal arm was at the
planned joints.
"""

from __future__ import annotations

import csv
import io
import re

import numpy as np
import pytest
from filter_kit import calibration, job

from calibrator.compensate import programs
from calibrator.languages import registry, writing
from calibrator.languages.spec import ProgramSpec
from calibrator.model import frames, inverse, kinematics, rotations

HOME = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
PLAN = np.array(
    [
        [0.1, -1.5, 1.2, -1.3, 1.2, 0.2],
        [0.4, -1.4, 1.1, -1.2, 1.4, 0.5],
        [0.7, -1.3, 1.0, -1.1, 1.6, 0.8],
    ]
)
VIAS = (
    np.zeros((0, 6)),
    np.array([[0.2, -1.6, 1.3, -1.3, 1.3, 0.3], [0.3, -1.7, 1.2, -1.3, 1.3, 0.4]]),
    np.zeros((0, 6)),
)
#: Writer format -> reader name, the reader's unit (rad or deg) and the order the moves'
#: joint targets stand in the file (h home, p0..p2 the poses, v1 v2 the vias of pose 1).
FORMATS = {
    "urscript": ("urscript", "rad", ["h", "p0", "v1", "v2", "p1", "p2"]),
    "krl": ("krl", "deg", ["h", "p0", "v1", "v2", "p1", "p2"]),
    "rapid": ("rapid", "deg", ["h", "p0", "v1", "v2", "p1", "p2"]),
    "fanuc-ls": ("fanuc", "deg", ["p0", "p1", "p2", "h", "v1", "v2"]),
}
#: Per format: the pulse statement and the wait after it (dwell 1.5 s, pulse 0.1 s:
#: URScript's sleep() waits the pulse out, so its wait is the rest).
WAITS = {
    "urscript": ("sleep(0.100)", "sleep(1.400)"),
    "krl": ("PULSE($OUT[2], TRUE, 0.10)", "WAIT SEC 1.500"),
    "rapid": ("PulseDO \\PLength:=0.10, do_calibrator;", "WaitTime \\InPos, 1.500;"),
    "fanuc-ls": ("DO[2]=PULSE,0.1sec ;", "WAIT 1.50(sec) ;"),
}


def _spec(**kw):
    args = dict(
        plan_rad=PLAN, home_rad=HOME, speed_rad_s=0.5, accel_rad_s2=1.0,
        max_joint_speed_rad_s=np.full(6, 3.0), dwell_s=1.5, pulse_output=2, name="meas",
        via_rad=VIAS,
    )  # fmt: skip
    args.update(kw)
    return ProgramSpec(**args)


def _joint_targets(fmt, path):
    """The joint targets the filter reads in ``path`` (N, 6), in file order."""
    name = FORMATS[fmt][0]
    cls = registry.readers()[name].cls
    lang = cls(job(calibration("ur10e", mm=0, rad=0)), path)
    found = [t for unit in lang.scan(path) for t in unit.targets]
    assert all(t.layout.kind == "joints" and t.problem is None for t in found), found
    return np.array([[float(v) for v in t.tokens] for t in found])


@pytest.mark.parametrize("fmt", sorted(FORMATS))
@pytest.mark.parametrize("vias", [True, False], ids=["vias", "no-vias"])
def test_a_written_program_reads_back_as_its_moves(tmp_path, fmt, vias):
    spec = _spec() if vias else _spec(via_rad=())
    path = tmp_path / f"meas{registry.writers()[fmt].suffixes[0]}"
    text = writing.render(spec, fmt)
    path.write_text(text)
    rows = {"h": HOME, "p0": PLAN[0], "p1": PLAN[1], "p2": PLAN[2], "v1": VIAS[1][0]}
    rows["v2"] = VIAS[1][1]
    order = [k for k in FORMATS[fmt][2] if vias or not k.startswith("v")]
    want = np.array([rows[k] for k in order])
    if FORMATS[fmt][1] == "deg":
        want = np.degrees(want)
    np.testing.assert_allclose(_joint_targets(fmt, path), want, atol=1e-6)
    # Every pose pulses and waits out the dwell; no via does.
    pulse, wait = WAITS[fmt]
    assert text.count(pulse) == 3 and text.count(wait) == 3, text


def test_the_table_lists_home_every_via_and_pose_and_home():
    rows = list(csv.DictReader(io.StringIO(writing.render(_spec(), "csv"))))
    assert [r["kind"] for r in rows] == ["home", "pose", "via", "via", "pose", "pose", "home"]
    assert [r["pose"] for r in rows] == ["", "0", "1", "1", "1", "2", ""]
    assert [r["dwell_s"] for r in rows] == ["0", "1.500", "0", "0", "1.500", "1.500", "0"]
    got = np.array([[float(r[f"q{i}_rad"]) for i in range(1, 7)] for r in rows])
    np.testing.assert_allclose(got, [HOME, PLAN[0], *VIAS[1], PLAN[1], PLAN[2], HOME])


def test_written_cartesian_targets_filtered_land_the_true_arm_on_the_planned_flange(tmp_path):
    """``program --targets cartesian`` then ``compensate``: each pose lands within 0.02 mm."""
    cal = calibration("ur10e", seed=7, mm=0.3, rad=0.0005)
    spec = _spec(targets="cartesian", mdh=cal.nominal_mdh, pulse_output=None)
    src = tmp_path / "meas.script"
    src.write_text(writing.render(spec, "urscript"))
    out = tmp_path / "out.script"
    summary = programs.Filter("urscript", job(cal), src).run(out, [src])
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == len(PLAN)
    written = [
        [float(v) for v in m.group(1).split(",")]
        for m in re.finditer(r"movej\(p\[([^\]]*)\]", out.read_text())
    ]
    sent = np.array(
        [
            frames.transform(rotations.rotvec_to_matrix(w[3:]), 1000.0 * np.array(w[:3]))
            for w in written
        ]
    )
    # The controller solves each pose from the joints it comes from (the via before pose 1).
    starts = np.array([HOME, VIAS[1][1], PLAN[1]])
    nominal = inverse.solve(cal.nominal_mdh, sent, starts)
    assert nominal.converged.all()
    np.testing.assert_allclose(nominal.q, PLAN, atol=0.01)  # the planned configuration
    reached = kinematics.chain(cal.mdh, nominal.q)
    planned = kinematics.chain(cal.nominal_mdh, PLAN)
    assert np.linalg.norm(reached[:, :3, 3] - planned[:, :3, 3], axis=1).max() < 0.02


def _trapezoid_s(lead, v=0.5, a=1.0):
    """A rest-to-rest move of ``lead`` rad at speed ``v`` and acceleration ``a``, s."""
    return lead / v + v / a if lead >= v * v / a else 2.0 * np.sqrt(lead / a)


def test_rapid_times_each_move_so_its_leading_joint_keeps_to_the_caps():
    r"""``\T`` is the trapezoid's duration of the largest joint step, rounded up to 0.01 s."""
    text = writing.render(_spec(), "rapid")
    times = np.array(re.findall(r"\\T:=([\d.]+)", text), dtype=float)
    path = np.array([HOME, PLAN[0], *VIAS[1], PLAN[1], PLAN[2], HOME])
    lead = np.abs(np.diff(path, axis=0)).max(axis=1)
    want = np.array([_trapezoid_s(v) for v in lead])
    assert len(times) == len(want)
    assert np.all(times >= want - 1e-9) and np.all(times <= want + 0.01 + 1e-9), (times, want)


def test_a_cartesian_coordinate_that_rounds_to_zero_is_written_without_a_sign():
    """The UR10e's flange at ``[0, -pi/2, 0, -pi/2, 0, 0]`` has x = -9e-17 m: ``0.000000000``."""
    upright = np.array([[0.0, -np.pi / 2, 0.0, -np.pi / 2, 0.0, 0.0]])
    spec = _spec(
        plan_rad=upright, via_rad=(), targets="cartesian", mdh=calibration("ur10e").nominal_mdh
    )
    text = writing.render(spec, "urscript")
    assert "movej(p[0.000000000, -0.290700000, 1.484800000, " in text
    assert "-0.000000000" not in text
