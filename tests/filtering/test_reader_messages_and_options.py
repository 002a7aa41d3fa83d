"""What a reader names and what it skips: configuration descriptions, motion options, the
kind of a cut-off target, a TCP change before any ``set_tcp``, and the summary's figures.

A failure names the configuration in the program's own notation (a Yaskawa
user reads ``RCONF``, not a bit list); KRL's ``WITH`` options after a move's
target are not targets; a ``T`` that is not a whole number fails like an
``S``; a URScript list cut off at its line's end counts as the kind of
target it opened (a pose ``p[`` or a joint list ``[``).
"""

from __future__ import annotations

import config_kit as kit
import numpy as np
import pytest
from filter_kit import calibration, job
from program_kit import krl_frame

from calibrator import robots
from calibrator.compensate import programs
from calibrator.languages.fanuc.reader import FanucLS
from calibrator.languages.jbi.reader import JBI
from calibrator.languages.krl.reader import KRL
from calibrator.languages.rapid.reader import RAPID
from calibrator.languages.reading import FilterError
from calibrator.languages.urscript.reader import URScript
from calibrator.model import frames, kinematics


@pytest.mark.parametrize(
    ("cls", "code", "text"),
    [
        (KRL, (6, 35), "S 6 T 35"),
        (RAPID, (-1, 0, 2, 5), "[-1,0,2,5]"),
        (FanucLS, (1, 0, 1, -1, 0, 1), "'F U B, -1, 0, 1'"),
        (JBI, (1, 0, 1, 0, 1, 0), "RCONF 1,0,1,0,1,0"),
        (URScript, (1, 0, 1), "back, up, flip"),
    ],
)
def test_a_configuration_is_described_in_the_languages_notation(cls, code, text):
    assert cls.__new__(cls).describe(code) == text


def _krl(tmp_path, moves):
    src = tmp_path / "OPT.src"
    src.write_text(f"DEF OPT()\n$TOOL = $NULLFRAME\n$BASE = $NULLFRAME\n{moves}END\n")
    (tmp_path / "out").mkdir()
    (tmp_path / "OPT.dat").write_text(f"DEFDAT OPT\nDECL E6POS XP1={{{_reachable()}}}\nENDDAT\n")
    return src


def _reachable():
    """A KR 6's flange pose in its base, as KRL's X..C with S and T, clear of singularities."""
    arm = robots.get("kuka-kr6-r900")
    q, codes = kit.space("kuka-kr6-r900", kit.CODES[KRL], n=2000)
    pose = frames.invert(arm.model_base2controller_base) @ kinematics.chain(arm.mdh, q[:1])[0]
    pose = pose @ arm.model_flange2controller_flange
    return f"{krl_frame(pose)},S {codes[0, 0]},T {codes[0, 1]}"


def test_krl_options_after_with_are_not_targets(tmp_path):
    src = _krl(tmp_path, "LIN XP1 WITH $VEL.CP = 0.2, $APO.CDIS = SPEED\n")
    cal = calibration("kuka-kr6-r900", mm=0.3, rad=0.0005)
    summary = programs.Filter("krl", job(cal), src).run(tmp_path / "out" / "OPT.src", [src])
    assert summary.n_failed == 0 and summary.corrected["pose"] == 1


@pytest.mark.parametrize("status", ["S 2.5,T 2", "S 2,T 2.5", "S 2,T x"])
def test_krl_status_and_turn_must_be_whole_numbers(tmp_path, status):
    pose = _reachable().split(",S ")[0]
    src = _krl(tmp_path, f"LIN {{{pose},{status}}}\n")
    cal = calibration("kuka-kr6-r900", mm=0.3, rad=0.0005)
    summary = programs.Filter("krl", job(cal, keep_failed=True), src).run(
        tmp_path / "out.src", [src]
    )
    reasons = [f["reason"] for f in summary.failures]
    assert len(reasons) == 1 and reasons[0] in (
        "S or T is not a whole number",
        "'x' is not a number",
    ), reasons


@pytest.mark.parametrize(
    ("line", "kind"), [("  movel(p[0.4, 0.1", "pose"), ("  movej([0.4, 0.1", "joints")]
)
def test_a_urscript_list_cut_off_counts_as_the_kind_it_opened(tmp_path, line, kind):
    src = tmp_path / "cut.script"
    src.write_text(f"def cut():\n{line}\nend\n")
    the_job = job(calibration("ur10e"), correct_joints=True, keep_failed=True)
    summary = programs.Filter("urscript", the_job, src).run(tmp_path / "out.script", [src])
    assert dict(summary.failed) == {kind: 1}


def test_a_variable_moved_to_before_any_set_tcp_and_after_one_is_refused(tmp_path):
    src = tmp_path / "tcp.script"
    src.write_text(
        "def tcp():\n  here = p[0.5, 0.1, 0.4, 0.0, 3.1, 0.0]\n  movel(here)\n"
        "  set_tcp(p[0, 0, 0.1, 0, 0, 0])\n  movel(here)\nend\n"
    )
    with pytest.raises(FilterError) as refused:
        programs.Filter("urscript", job(calibration("ur10e")), src)
    assert str(refused.value) == (
        f"{src}:5: here is moved to with the TCP set on line 4 here and the TCP of line none "
        "before; one target cannot be corrected for two tools"
    )


def test_the_summarys_figures_are_the_runs(tmp_path):
    src = _krl(tmp_path, "LIN XP1\n")
    cal = calibration("kuka-kr6-r900", mm=0.3, rad=0.0005)
    summary = programs.Filter("krl", job(cal), src).run(tmp_path / "out" / "OPT.src", [src])
    doc = summary.to_json()
    assert doc["correction"] == {
        "max_mm": summary.max_mm, "mean_mm": summary.max_mm,
        "max_deg": summary.max_deg, "mean_deg": summary.max_deg,
    }  # fmt: skip
    assert 0 < summary.max_mm < 5 and 0 < summary.max_deg < 1
    assert doc["targets"] == {"pose": {"found": 1, "corrected": 1, "kept": 0, "failed": 0}}
    assert np.isclose(summary.sum_mm, summary.max_mm)
