"""No garbled program, exit 0: malformed numbers, strings, skipped targets, duplicates, binaries.

Each case takes a program the filter corrects whole and breaks one target the
way an adversarial pass did (issue 41): the target must fail, named with its
file and line, or the program be refused in one line; never corrected with
its columns shifted, never skipped while the rest is "corrected".
"""

import re

import numpy as np
import pytest
from cli_kit import cli, one_line_error
from filter_kit import BASE, TOOL, TOOL2, calibration, job, path_joints, work_joints
from program_kit import (
    PPD,
    write_fanuc_ls,
    write_jbi_job,
    write_krl_program,
    write_rapid_module,
    write_urscript,
)

from calibrator.compensate import programs
from calibrator.languages import frames_file
from calibrator.languages.reading import FilterError

FRAMES = frames_file.FrameTable(
    tools={"1": TOOL, "2": TOOL2},
    bases={"1": BASE, "2": BASE},
    pulses_per_degree=np.array(PPD),
)


def _program(tmp_path, lang):
    """A program of ``lang`` the filter corrects whole, its calibration and job."""
    if lang == "urscript":
        cal = calibration("ur10e")
        return write_urscript(tmp_path / "p.script", cal, path_joints(5, model="ur10e")), cal, {}
    cal = calibration()
    if lang == "krl":
        src, config = write_krl_program(tmp_path, cal, work_joints(4))
        return src, cal, {"config_dat": config}
    writer, name = {
        "jbi": (write_jbi_job, "p.jbi"),
        "fanuc": (write_fanuc_ls, "p.ls"),
        "rapid": (write_rapid_module, "p.mod"),
    }[lang]
    return writer(tmp_path / name, cal, work_joints(6)), cal, {}


#: (language, pattern of the first number of one target, the line it is on).
FIRST_NUMBER = {
    "jbi": (r"(?m)^C00001=([^,]*)", "C00001"),
    "fanuc": (r"X = +([-\d.]+)", "P[2]"),
    "urscript": (r"movel\(p\[([^,]*)", "movel"),
    "krl": (r"XP1=\{X ([^,]*)", "XP1"),
    "rapid": (r"p10:=\[\[([^,]*)", "p10"),
}


def _holder(src, lang):
    """The file holding the targets of FIRST_NUMBER (KRL: the .dat beside the .src)."""
    return src.with_suffix(".dat") if lang == "krl" else src


def _break(src, lang, replacement):
    """Replace the first number of one target by ``replacement``; its file and line."""
    path = _holder(src, lang)
    raw = path.read_bytes().decode("latin-1")
    pattern, _ = FIRST_NUMBER[lang]
    m = re.search(pattern, raw)
    path.write_bytes((raw[: m.start(1)] + replacement + raw[m.end(1) :]).encode("latin-1"))
    return path, raw[: m.start(1)].count("\n") + 1


def _filter(lang, cal, src, tmp_path, **kw):
    out = tmp_path / ("o" + src.suffix)
    summary = programs.Filter(lang, job(cal, FRAMES, **kw), src).run(out, [src])
    return summary, out


LANGS = ["jbi", "fanuc", "urscript", "krl", "rapid"]


@pytest.mark.parametrize("lang", LANGS)
def test_every_program_here_is_corrected_whole_before_it_is_broken(tmp_path, lang):
    src, cal, kw = _program(tmp_path, lang)
    summary, out = _filter(lang, cal, src, tmp_path, **kw)
    assert summary.n_failed == 0, summary.failures
    assert out.exists()


@pytest.mark.parametrize("lang", LANGS)
@pytest.mark.parametrize(
    "bad, reason",
    [
        ("1.2.3", "'1.2.3' is not a number"),
        ("nan", "'nan' is not a number"),
        ("1e999", "not a finite number"),
        ("", "an empty number"),
    ],
)
def test_a_malformed_number_fails_its_target_named_with_its_line(tmp_path, lang, bad, reason):
    src, cal, kw = _program(tmp_path, lang)
    path, line = _break(src, lang, bad)
    summary, out = _filter(lang, cal, src, tmp_path, **kw)
    assert summary.n_failed == 1, summary.failures
    failure = summary.failures[0]
    assert failure["file"] == str(path) and failure["line"] == line, failure
    assert failure["target"] == FIRST_NUMBER[lang][1]
    assert reason in failure["reason"], failure
    assert not out.exists()  # nothing written: one target failed


@pytest.mark.parametrize(
    "lang, cut",
    [
        ("jbi", r"(?m)^(C00001=[^,]*,[^,]*,[^,]*),.*$"),
        ("fanuc", r"(?s)(P\[2\]\{.*?Z = +[-\d.]+  mm,)[^}]*?deg\r?\n"),
        ("urscript", r"(movel\(p\[[^,]*,[^,]*),.*"),
        ("krl", r"(XP1=\{X [^,]*,Y [^,]*),.*"),
    ],
)
def test_a_truncated_target_fails_instead_of_being_skipped(tmp_path, lang, cut):
    src, cal, kw = _program(tmp_path, lang)
    path = _holder(src, lang)
    raw = path.read_bytes().decode("latin-1")
    m = re.search(cut, raw)
    path.write_bytes((raw[: m.end(1)] + raw[m.end() :]).encode("latin-1"))
    summary, out = _filter(lang, cal, src, tmp_path, **kw)
    assert summary.n_failed == 1, (summary.failures, dict(summary.corrected))
    assert summary.failures[0]["target"] == FIRST_NUMBER[lang][1]
    assert not out.exists()


def test_a_move_inside_a_urscript_string_or_comment_is_no_target(tmp_path):
    src, cal, _ = _program(tmp_path, "urscript")
    raw = src.read_bytes().decode("utf-8")
    good = _filter("urscript", cal, src, tmp_path)[0]
    n = good.corrected["pose"]
    unreachable = "p[9.0, 9.0, 9.0, 0.0, 0.0, 0.0]"
    extra = (
        f'  textmsg("movel({unreachable})")\r\n'
        f"  popup('movej({unreachable}, a=1)', title=\"x # y\")\r\n"
        f"  # movel({unreachable})\r\n"
    )
    at = raw.index("  movel(")
    src.write_bytes((raw[:at] + extra + raw[at:]).encode("utf-8"))
    (tmp_path / "o.script").unlink()
    summary, out = _filter("urscript", cal, src, tmp_path)
    assert summary.n_failed == 0, summary.failures
    assert summary.corrected["pose"] == n
    # The strings and the comment are written back untouched.
    assert extra in out.read_bytes().decode("utf-8")


def test_a_urscript_set_tcp_inside_a_string_changes_no_tool(tmp_path):
    src, cal, _ = _program(tmp_path, "urscript")
    before = _filter("urscript", cal, src, tmp_path)[1].read_bytes()
    raw = src.read_bytes().decode("utf-8")
    at = raw.index("  approach")
    line = '  textmsg("set_tcp(p[0, 0, 0.5, 0, 0, 0])")\r\n'
    src.write_bytes((raw[:at] + line + raw[at:]).encode("utf-8"))
    (tmp_path / "o.script").unlink()
    after = _filter("urscript", cal, src, tmp_path)[1].read_bytes()
    assert after.replace(line.encode(), b"") == before


def test_krl_names_that_differ_in_case_are_one_name_declared_twice(tmp_path):
    src, cal, kw = _program(tmp_path, "krl")
    dat = src.with_suffix(".dat")
    raw = dat.read_bytes().decode("cp1252")
    line = next(x for x in raw.split("\r\n") if x.startswith("DECL E6POS XP1="))
    dat.write_bytes(
        raw.replace("ENDDAT", line.replace("XP1", "xp1") + "\r\nENDDAT").encode("cp1252")
    )
    with pytest.raises(FilterError, match=r"weld\.dat:\d+: xp1 is declared again"):
        _filter("krl", cal, src, tmp_path, **kw)


def test_two_fanuc_positions_of_one_number_are_refused(tmp_path):
    src, cal, _ = _program(tmp_path, "fanuc")
    raw = src.read_bytes().decode("utf-8")
    raw = raw.replace('P[3:"Naht 1"]{', 'P[2:"again"]{')
    src.write_bytes(raw.encode("utf-8"))
    with pytest.raises(FilterError, match=r"P\[2\] is defined again \(first on line \d+\)"):
        _filter("fanuc", cal, src, tmp_path)
    assert not (tmp_path / "o.ls").exists()


def test_two_jbi_positions_of_one_number_are_refused(tmp_path):
    src, cal, _ = _program(tmp_path, "jbi")
    raw = src.read_bytes().decode("ascii").replace("C00002=", "C00001=")
    src.write_bytes(raw.encode("ascii"))
    with pytest.raises(FilterError, match="position C00001 is defined again"):
        _filter("jbi", cal, src, tmp_path)


def test_a_fanuc_comment_holding_a_value_is_not_read(tmp_path):
    src, cal, _ = _program(tmp_path, "fanuc")
    before = _filter("fanuc", cal, src, tmp_path)[1].read_bytes()
    (tmp_path / "o.ls").unlink()
    raw = src.read_bytes().decode("utf-8")
    src.write_bytes(raw.replace('P[3:"Naht 1"]{', 'P[3:"X = 5 mm"]{').encode("utf-8"))
    summary, out = _filter("fanuc", cal, src, tmp_path)
    assert summary.n_failed == 0, summary.failures
    assert out.read_bytes() == before.replace(b'P[3:"Naht 1"]', b'P[3:"X = 5 mm"]')


# -- the command line: refusals in one line, exit 2, nothing written -------------------


def _cli_case(tmp_path, lang):
    src, cal, kw = _program(tmp_path, lang)
    cal.save(tmp_path / "cal.json")
    (tmp_path / "f.yaml").write_text(
        "tools:\n  '1': {xyz_mm: [0, 0, 1], abc_deg: [0, 0, 0]}\n"
        "bases:\n  '1': {xyz_mm: [0, 0, 1], abc_deg: [0, 0, 0]}\n"
    )
    extra = ["--config-dat", kw["config_dat"].name] if "config_dat" in kw else []
    return src, extra


@pytest.mark.parametrize("lang", LANGS)
def test_binary_bytes_named_as_a_program_are_refused(tmp_path, lang):
    src, extra = _cli_case(tmp_path, lang)
    src.write_bytes(bytes(range(256)) * 8)
    out = "o" + src.suffix
    done = cli("compensate", "cal.json", src.name, "-o", out, *extra, cwd=tmp_path)
    assert "binary bytes" in one_line_error(done)
    assert not (tmp_path / out).exists()


def test_a_binary_config_dat_is_refused(tmp_path):
    src, extra = _cli_case(tmp_path, "krl")
    (tmp_path / extra[1]).write_bytes(b"TOOL_DATA[1]={X 0}\x00\x01\x02\xff\n")
    done = cli("compensate", "cal.json", src.name, "-o", "o.src", *extra, cwd=tmp_path)
    assert "config.dat:1: binary bytes" in one_line_error(done)
    assert not (tmp_path / "o.src").exists() and not (tmp_path / "o.dat").exists()


def test_a_krl_src_whose_points_are_in_no_dat_is_refused(tmp_path):
    src, extra = _cli_case(tmp_path, "krl")
    src.with_suffix(".dat").unlink()
    done = cli("compensate", "cal.json", src.name, "-o", "o.src", *extra, cwd=tmp_path)
    line = one_line_error(done)
    assert "weld.src:9: XP1 is moved to but declared in no .dat" in line, line
    assert not (tmp_path / "o.src").exists()


def test_krl_dat_beside_the_output_is_protected_like_the_output(tmp_path):
    src, extra = _cli_case(tmp_path, "krl")
    (tmp_path / "out").mkdir()
    mine = tmp_path / "out" / "weld.dat"
    mine.write_bytes(b"DEFDAT WELD\r\n; my own points\r\nENDDAT\r\n")
    args = ("compensate", "cal.json", src.name, "-o", "out/weld.src", *extra)
    line = one_line_error(cli(*args, cwd=tmp_path))
    assert "out/weld.dat exists: remove it" in line and "--force" in line, line
    assert mine.read_bytes() == b"DEFDAT WELD\r\n; my own points\r\nENDDAT\r\n"
    assert not (tmp_path / "out" / "weld.src").exists()
    done = cli(*args, "--force", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert mine.read_bytes() != b"DEFDAT WELD\r\n; my own points\r\nENDDAT\r\n"


def test_a_cut_off_rapid_target_fails_alone_and_the_next_statement_is_read(tmp_path):
    src, cal, _ = _program(tmp_path, "rapid")
    raw = src.read_bytes().decode("latin-1")
    m = re.search(r"(p10:=\[\[[^,]*,[^,]*),.*", raw)
    src.write_bytes((raw[: m.end(1)] + raw[m.end() :]).encode("latin-1"))
    summary, out = _filter("rapid", cal, src, tmp_path)
    assert [f["target"] for f in summary.failures] == ["p10"], summary.failures
    assert summary.corrected["pose"] == 4, dict(summary.corrected)  # p20.. and the inline one
    assert not out.exists()
