"""Program-filter cases the filtering tests did not reach. Found by mutation testing (issue 44).

A corrected value that one more decimal carries is written with exactly one
more; a URScript list cut off at the end of its line (a pose variable's
assignment, a move's literal) fails naming its file, line and why; a
comment holding a second comment mark and a move stays a comment, and a line
with strings keeps its length; a Fanuc position without its UT number fails
saying so.
"""

from __future__ import annotations

from filter_kit import BASE, TOOL, calibration, frame_yaml, job, work_joints
from program_kit import write_fanuc_ls

from calibrator.compensate import programs
from calibrator.languages import frames_file, numbers
from calibrator.languages.lexing import Lexer


def test_one_more_decimal_is_one_more_not_two():
    assert numbers.write("1.0", 1.04, "mm") == "1.04"
    assert numbers.write("45.0", 45.023, "deg") == "45.023"


def test_a_list_cut_off_at_its_line_end_fails_naming_the_file_and_why(tmp_path):
    lines = [
        "def cut():",
        "  set_tcp(p[0.0, 0.0, 0.1, 0.0, 0.0, 0.0])",
        "  home = p[0.5, 0.1, 0.4, 0.0, 3.1, 0.0]",
        "  movel(home, a=1.2, v=0.25)",
        "  home = p[0.5, 0.2",
        "  movel(p[0.4, 0.1",
        "end",
        "",
    ]
    src = tmp_path / "cut.script"
    src.write_text("\n".join(lines))
    summary = programs.Filter("urscript", job(calibration("ur10e", seed=2)), src).run(
        tmp_path / "out.script", [src]
    )
    unclosed = "its list is not closed on its line"
    assert summary.failures == [
        {"file": str(src), "line": 5, "target": "home", "reason": unclosed},
        {"file": str(src), "line": 6, "target": "movel", "reason": unclosed},
    ]


URSCRIPT = Lexer(quotes="\"'", comment="#")


def test_a_comment_mark_inside_a_comment_does_not_reopen_code():
    line = "x = 1  # see # movel(p[1, 2, 3, 4, 5, 6])"
    assert URSCRIPT.code(line) == "x = 1  " + " " * (len(line) - 7)


def test_strings_are_blanked_in_place():
    line = 'textmsg("movel(p[1])") movel(p[0.1, 0.2])'
    code = URSCRIPT.code(line)
    assert code == 'textmsg("' + " " * len("movel(p[1])") + '") movel(p[0.1, 0.2])'
    assert len(code) == len(line)


def test_a_fanuc_position_without_its_ut_number_fails_saying_so(tmp_path):
    cal = calibration()
    src = write_fanuc_ls(tmp_path / "weld.ls", cal, work_joints(3))
    text = src.read_bytes().decode()
    first = text.index("\tUF : 1, UT : 1,\t\tCONFIG")
    src.write_bytes((text[:first] + text[first:].replace("UT : 1,", "", 1)).encode())
    table = tmp_path / "frames.yaml"
    table.write_text(f"tools:\n  '1': {frame_yaml(TOOL)}\nbases:\n  '1': {frame_yaml(BASE)}\n")
    summary = programs.Filter("fanuc", job(cal, frames_file.read(table)), src).run(
        tmp_path / "o.ls", [src]
    )
    (fail,) = summary.failures
    assert fail["target"] == "P[2]" and "no UT number" in fail["reason"], fail
