"""Every Python block in docs/external-robots.md runs as written."""

import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "external-robots.md"
BLOCKS = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_page_has_examples():
    assert BLOCKS


@pytest.mark.parametrize("block", BLOCKS)
def test_example_runs(block, capsys):
    if block.startswith("# requires hardware"):
        compile(block, str(DOC), "exec")
        return
    exec(compile(block, str(DOC), "exec"), {})
