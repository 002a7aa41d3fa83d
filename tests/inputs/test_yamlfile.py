"""The one YAML reader: size, depth and alias limits, duplicate keys, used by every YAML input."""

import re
import time
from pathlib import Path

import pytest
from cli_kit import cli, listing, one_line_error
from hypothesis import given, settings
from hypothesis import strategies as st

from calibrator.inputs import yamlfile
from calibrator.inputs.errors import StrictError


def _bomb(levels: int, where: str) -> str:
    """A cell file whose obstacle names nest aliases 9**levels values wide (a "billion laughs")."""
    lines = ["obstacles:"]
    for i in range(levels):
        name = "[lol, lol, lol, lol, lol, lol, lol, lol, lol]"
        if i:
            name = "[" + ", ".join([f"*a{i - 1}"] * 9) + "]"
        lines.append(f"  - box: {{name: &a{i} {name}, min_mm: [0, 0, 0], max_mm: [1, 1, 1]}}")
    last = "[" + ", ".join([f"*a{levels - 1}"] * 9) + "]"
    if where == "name":
        lines.append(f"  - box: {{name: {last}, min_mm: [0, 0, 0], max_mm: [1, 1, 1]}}")
    elif where == "margin_mm":
        lines.append(f"margin_mm: {last}")
    elif where == "min_mm":
        lines.append(f"  - box: {{min_mm: {last}, max_mm: [1, 1, 1]}}")
    else:
        lines.append(f"tracker: {{at_mm: {last}}}")
    return "\n".join(lines) + "\n"


HOSTILE = {
    "nested 1,000 deep (flow)": ("obstacles: " + "[" * 1000 + "]" * 1000 + "\n", "nested more"),
    "nested 300 deep (block)": (
        "a:\n" + "".join("  " * i + f"k{i}:\n" for i in range(1, 300)) + "  " * 300 + "x: 1\n",
        "nested more than 64 deep",
    ),
    "a duplicate key": ("margin_mm: 20\nmargin_mm: 30\n", "key 'margin_mm' appears more than once"),
    "a duplicate nested key": (
        "tracker:\n  at_mm: [2500, 0, 0]\n  at_mm: [0, 0, 0]\n",
        "key 'at_mm' appears more than once (line 3)",
    ),
    "an alias of itself": ("a: &x [1, *x]\n", "alias *x refers to itself"),
    **{
        f"an alias bomb in {where}": (_bomb(9, where), "aliases expand to more than")
        for where in ("name", "margin_mm", "min_mm", "tracker.at_mm")
    },
}


@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_a_hostile_cell_file_is_one_line_naming_the_file(tmp_path, case):
    text, says = HOSTILE[case]
    (tmp_path / "cell.yaml").write_text(text)
    before = listing(tmp_path)
    started = time.perf_counter()
    line = one_line_error(
        cli("plan", "--cell", "cell.yaml", "--poses", "5", "-o", "p.csv", cwd=tmp_path)
    )
    assert time.perf_counter() - started < 5
    assert line.startswith("calibrator: error: cell.yaml: ")
    assert says in line and len(line) < 200
    assert listing(tmp_path) == before


def test_a_file_above_its_size_is_refused_unread(tmp_path):
    path = tmp_path / "big.yaml"
    path.write_text("a: " + "x" * 2000 + "\n")
    with pytest.raises(StrictError, match=r"big.yaml: 2004 bytes is too large .*1000"):
        yamlfile.read(path, "a test file", max_bytes=1000)


def test_the_limits_themselves_pass():
    n = yamlfile.MAX_DEPTH - 1  # inside the top mapping
    assert yamlfile.loads("a: " + "[" * n + "]" * n + "\n") is not None
    with pytest.raises(StrictError, match="nested more than 64 deep"):
        yamlfile.loads("a: " + "[" * (n + 1) + "]" * (n + 1) + "\n")
    # A few aliases that expand modestly are ordinary YAML and read as such.
    doc = yamlfile.loads("base: &b {x: 1.5, y: 2}\none: *b\ntwo: {<<: *b, y: 3}\n")
    assert doc == {"base": {"x": 1.5, "y": 2}, "one": {"x": 1.5, "y": 2}, "two": {"x": 1.5, "y": 3}}


def test_numbers_follow_the_strict_grammar():
    assert yamlfile.loads("x: 1e-3\nn: -2\n") == {"x": 0.001, "n": -2}
    for text in ("x: 0x10\n", "x: 1_000\n", "x: .inf\n", "x: 017\n", "x: 99999999999999999999\n"):
        with pytest.raises(StrictError, match="^f.yaml: "):
            yamlfile.loads(text, "f.yaml")


def test_every_yaml_input_reads_through_this_reader():
    """No module of the package parses YAML any other way."""
    root = Path(__file__).resolve().parents[2]
    for path in [*(root / "calibrator").rglob("*.py"), *(root / "drivers").rglob("*.py")]:
        if path.name == "yamlfile.py":
            continue
        text = path.read_text()
        assert not re.search(r"yaml\.(safe_load|load|full_load|unsafe_load)\(", text), path


@pytest.mark.parametrize(
    ("name", "text", "says"),
    [
        ("sections.yaml", "links:\n  2: {outer_mm: 1}\n  2: {outer_mm: 2}\n", "appears more than"),
        ("masses.yaml", "links: " + "[" * 100 + "]" * 100 + "\n", "nested more than"),
    ],
)
def test_sections_and_mass_models_read_through_it_too(tmp_path, name, text, says):
    (tmp_path / name).write_text(text)
    option = "--sections" if name == "sections.yaml" else "--masses"
    extra = [] if option == "--sections" else ["--sections", "ok.yaml"]
    (tmp_path / "ok.yaml").write_text("links:\n  2: {outer_mm: 120, inner_mm: 100}\n")
    line = one_line_error(
        cli("analyze", "deflection", "--model", "ur10e", option, name, *extra, cwd=tmp_path)
    )
    assert f"{name}: " in line and says in line


# Fuzz: any text is a document or one StrictError line, within the limits, quickly.
_PIECES = st.sampled_from(
    ["a: ", "- ", "[", "]", "{", "}", ", ", ": ", "&x ", "*x", "&y ", "*y", "<<: ", "\n", "  ",
     "1", "1e-3", "0x1F", ".nan", "017", "'q'", '"\\u0000"', "!!binary aGk=", "!!python/name:os",
     "? ", "|\n  t", "%YAML 1.1\n", "---\n", "...\n", "~", "true", "b: ", "a: "]
)  # fmt: skip


@settings(max_examples=300, deadline=None)
@given(pieces=st.lists(_PIECES, max_size=40))
def test_fuzz_any_text_is_a_document_or_one_line(pieces):
    text = "".join(pieces)
    started = time.perf_counter()
    try:
        yamlfile.loads(text, "f.yaml")
    except StrictError as exc:
        message = str(exc)
        assert message.startswith("f.yaml: ") and "\n" not in message and len(message) < 300
    assert time.perf_counter() - started < 2
