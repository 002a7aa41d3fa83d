"""The exporter registry: a registered format is chosen by ``--format`` or by the
output's extension and written by its own function; unknown or mismatched
formats are refused in one line (exit 2 from the command line)."""

import json

import pytest
import yaml
from cli_kit import cli, one_line_error
from export_kit import calibrated

from calibrator import export
from calibrator.errors import CalibrationError


@pytest.fixture
def toy_format():
    """A format registered for the test only, removed afterwards."""
    calls = []

    def write(cal):
        calls.append(cal)
        return export.Exported(f"toy of {cal.model}\n", ["toy note"])

    returned = export.exporter("toy-test", [".toy", ".toy.txt"], "a toy format for tests")(write)
    yield write, returned, calls
    export.REGISTRY.pop("toy-test", None)


def test_a_registered_format_is_listed_chosen_and_written(toy_format):
    write, returned, calls = toy_format
    assert returned is write  # the decorator leaves the function usable
    fmt = export.REGISTRY["toy-test"]
    assert (fmt.name, fmt.suffixes, fmt.help, fmt.write) == (
        "toy-test",
        (".toy", ".toy.txt"),
        "a toy format for tests",
        write,
    )
    assert export.format_names()[-1] == "toy-test"
    assert export.choose(None, "cell/OUT.TOY") == "toy-test"
    assert export.choose(None, "out.toy.txt") == "toy-test"
    assert export.choose("toy-test", "x.toy") == "toy-test"
    assert export.choose("toy-test") == "toy-test"
    cal = calibrated()
    done = export.export(cal, "toy-test")
    assert done.text == "toy of ur10e\n" and done.notes == ["toy note"]
    assert calls == [cal]


def test_builtin_formats_in_registration_order():
    # The order of the --format choices: the package imports its modules in it.
    assert export.format_names() == ("json", "csv", "ur-calibration", "ros-kinematics", "urdf")


@pytest.mark.parametrize(
    ("name", "fmt"),
    [
        ("a.json", "json"),
        ("A.CSV", "csv"),
        ("arm.urcal", "ur-calibration"),
        ("arm.conf", "ur-calibration"),
        ("kin.yaml", "ros-kinematics"),
        ("kin.yml", "ros-kinematics"),
        ("arm.urdf", "urdf"),
        ("dir.urdf/arm.json", "json"),
    ],
)
def test_format_from_the_extension(name, fmt):
    assert export.choose(None, name) == fmt


def test_the_longest_matching_suffix_wins(toy_format):
    # ".toy.txt" is longer than any ".txt"-like suffix a later format may add.
    export.exporter("short-test", [".txt"], "short")(lambda cal: export.Exported(""))
    try:
        assert export.choose(None, "a.toy.txt") == "toy-test"
        assert export.choose(None, "a.txt") == "short-test"
    finally:
        export.REGISTRY.pop("short-test")


def test_unknown_format_is_refused_with_the_known_ones():
    known = ", ".join(export.REGISTRY)
    with pytest.raises(CalibrationError) as info:
        export.choose("xml", None)
    assert str(info.value) == f"unknown format 'xml'; known: {known}"
    with pytest.raises(CalibrationError) as info:
        export.choose("xml", "out.xml")
    assert str(info.value) == f"unknown format 'xml'; known: {known}"
    with pytest.raises(CalibrationError) as info:
        export.export(calibrated(), "xml")
    assert str(info.value) == f"unknown format 'xml'; known: {known}"


def test_a_format_that_does_not_match_the_extension_is_refused():
    with pytest.raises(CalibrationError) as info:
        export.choose("ur-calibration", "out.json")
    assert str(info.value) == (
        "output out.json does not end in .urcal or .conf, the extension of format ur-calibration"
    )
    with pytest.raises(CalibrationError) as info:
        export.choose(None, "out.xml")
    assert str(info.value) == (
        "cannot tell the format from out.xml: give --format or end the name in one of "
        ".json, .csv, .urcal, .conf, .yaml, .yml, .urdf"
    )
    assert export.choose(None, None) == "json"


def test_export_params_writes_the_format_of_the_extension(tmp_path):
    cal = calibrated()
    cal.save(tmp_path / "cal.json")
    done = cli("export-params", "cal.json", "-o", "kin.yml", cwd=tmp_path)
    assert done.code == 0, done.stderr
    assert done.stdout == "wrote kin.yml (ros-kinematics)\n"
    assert yaml.safe_load((tmp_path / "kin.yml").read_text()) == yaml.safe_load(
        export.export(cal, "ros-kinematics").text
    )
    # --format wins over the default (json to stdout).
    shown = cli("export-params", "cal.json", "--format", "urdf", cwd=tmp_path)
    assert shown.code == 0 and shown.stdout == export.export(cal, "urdf").text
    plain = cli("export-params", "cal.json", cwd=tmp_path)
    assert json.loads(plain.stdout)["model"] == "ur10e"


def test_export_params_prints_the_notes_on_stderr(tmp_path):
    cal = calibrated(trailing=True)
    cal.save(tmp_path / "cal.json")
    done = cli("export-params", "cal.json", "-o", "kin.yaml", cwd=tmp_path)
    assert done.code == 0
    notes = export.export(cal, "ros-kinematics").notes
    assert len(notes) == 1
    assert done.stderr == f"note: {notes[0]}\n"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--format", "json", "-o", "out.xml"), "out.xml does not end in .json"),
        (("-o", "out.xml"), "cannot tell the format from out.xml"),
        (("-o", "cal.json"), "cal.json"),
    ],
)
def test_export_params_refusals_are_one_line_and_write_nothing(tmp_path, args, words):
    calibrated().save(tmp_path / "cal.json")
    before = (tmp_path / "cal.json").read_bytes()
    line = one_line_error(cli("export-params", "cal.json", *args, cwd=tmp_path))
    assert words in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json"]
    assert (tmp_path / "cal.json").read_bytes() == before


def test_export_params_with_an_unknown_format_is_a_usage_error(tmp_path):
    calibrated().save(tmp_path / "cal.json")
    done = cli("export-params", "cal.json", "--format", "xml", cwd=tmp_path)
    assert done.code == 2 and "xml" in done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json"]
