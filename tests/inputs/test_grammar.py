"""The one number grammar, JSON loader, YAML loader and budget check (calibrator.inputs)."""

import json

import numpy as np
import pytest

from calibrator.errors import CalibrationError
from calibrator.inputs import budgets, grammar, jsonfile, textfile, yamlfile
from calibrator.inputs.errors import StrictError


@pytest.mark.parametrize(
    ("text", "value"),
    [("0.5", 0.5), ("-1e-3", -0.001), (".5", 0.5), ("5.", 5.0), (" 3 ", 3.0), ("+2E+2", 200.0)],
)
def test_decimal_numbers_read_as_numbers(text, value):
    assert grammar.parse_number(text) == value


@pytest.mark.parametrize(
    "text", ["0_5", "1_000.0", "0x10", "nan", "NaN", "inf", "-Infinity", "", "1,5", "1e400", "١"]
)
def test_anything_else_is_refused_naming_the_text(text):
    with pytest.raises(StrictError) as info:
        grammar.parse_number(text, "plan.csv row 2, q1_rad")
    assert str(info.value).startswith("plan.csv row 2, q1_rad: ")


def test_python_float_would_have_read_an_underscore_as_a_digit_separator():
    # The reason for the grammar: float() reads "0_5" as 5.0, silently.
    assert float("0_5") == 5.0
    with pytest.raises(StrictError, match="'0_5' is not a decimal number"):
        grammar.parse_number("0_5")


def test_parse_columns_names_line_and_column():
    assert grammar.parse_columns([["1", "2"], ["3", "4.5"]], "ab", "t").tolist() == [
        [1, 2],
        [3, 4.5],
    ]
    with pytest.raises(StrictError, match=r"^t.csv: line 3, a: '0x1' is not"):
        grammar.parse_columns([["1", "2"], ["0x1", "4"]], "ab", "t.csv")
    assert grammar.parse_numbers(["1", "-2e1"]).tolist() == [1.0, -20.0]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"model": "ur10e", "model": "ur5e"}', "f: key 'model' appears more than once"),
        ('{"a": {"b": [1, 2], "b": 3}}', "f: key 'b' appears more than once"),
        (
            '{"a": [1, ' + "9" * 400 + "]}",
            "f: a[1]: the integer '99999999999999999999...' is beyond 64 bits",
        ),
        (
            '{"a": ' + "9" * 5000 + "}",
            "f: a: the integer '99999999999999999999...' is beyond 64 bits",
        ),
        ('{"a": 9223372036854775808}', "f: a: the integer '9223372036854775808' is beyond 64 bits"),
        ('{"a": 1e400}', "f: a: '1e400' is too large for a number"),
        ('{"a": NaN}', "f: a: NaN is not allowed (strict JSON)"),
        # A key a line cannot show as is (newline, dot, empty) is quoted in the path.
        ('{"a": {"\\n": 1e400}}', "f: a['\\n']: '1e400' is too large for a number"),
        ('{"x.y": [NaN]}', "f: ['x.y'][0]: NaN is not allowed (strict JSON)"),
        ('{"": NaN}', "f: ['']: NaN is not allowed (strict JSON)"),
        ("[Infinity]", "f: [0]: Infinity is not allowed (strict JSON)"),
        ("{", "f is not JSON"),
        ("[" * 100000, "f is not JSON"),
        (b'"\xff"', "f is not JSON"),
    ],
)
def test_json_refusals_are_one_line_naming_the_key(text, message):
    with pytest.raises(CalibrationError) as info:
        jsonfile.load_json(text, "f")
    assert str(info.value) == message


def test_json_keeps_what_python_reads_the_same():
    text = '{"a": [1, -2.5e-3, true, null, "x"], "b": {"c": 9223372036854775807}}'
    assert jsonfile.load_json(text) == json.loads(text)


@pytest.mark.parametrize(
    "text",
    [
        "a: 1\na: 2",
        "a: 0x1F",
        "a: 1_000",
        "a: 1:30",
        "a: .nan",
        "a: -.inf",
        "a: 0o17",
        "a: 017",
        "a: 1e400",
        "a: " + "9" * 30,
        "a: [1, 2",
    ],
)
def test_yaml_refuses_what_yaml_1_1_would_convert_silently(text):
    with pytest.raises(StrictError) as info:
        yamlfile.loads(text, "k.yaml")
    assert str(info.value).startswith("k.yaml")
    assert "\n" not in str(info.value)


def test_yaml_reads_numbers_by_the_same_grammar():
    # YAML 1.1 (PyYAML) reads "1e-3" as text; the grammar reads it as the number it is.
    assert yamlfile.loads("x: 1e-3\ny: 1.5\nz: -2\nw: [0.5, 3]\nn: name") == {
        "x": 0.001,
        "y": 1.5,
        "z": -2,
        "w": [0.5, 3],
        "n": "name",
    }


def test_budget_refuses_above_the_limit_in_one_line():
    budgets.check_budget("--trials", 10**9, 10**9, "trials")
    with pytest.raises(StrictError) as info:
        budgets.check_budget("--trials", 10**12, 10**9, "trials")
    assert (
        str(info.value)
        == "--trials: 1000000000000 trials is more than the limit of 1000000000 trials"
    )
    with pytest.raises(StrictError, match="about 1e400"):
        budgets.check_budget("--poses", 10**400, 50_000)
    with pytest.raises(StrictError):
        budgets.check_budget("--settle", float("nan"), 60.0, "s")


def test_read_text_refuses_large_or_binary_files(tmp_path):
    path = tmp_path / "f.yaml"
    path.write_bytes(b"a: 1\n")
    assert textfile.read_text(path, 5) == "a: 1\n"
    with pytest.raises(StrictError, match="6 bytes is too large"):
        path.write_bytes(b"a: 1\n\n")
        textfile.read_text(path, 5)
    path.write_bytes(b"\xff\xfe")
    with pytest.raises(StrictError, match="not a text file \\(not UTF-8 text\\)"):
        textfile.read_text(path, 5)
    assert np.isfinite(grammar.MAX_INT)
