"""No code outside calibrator/robots/ switches on an arm's name."""

import re
from pathlib import Path

import calibrator

ROOT = Path(calibrator.__file__).parent
# The issue's own check: grep -rn '== "ur\|startswith("ur\|er10l' calibrator --include=*.py
PATTERN = re.compile(r'== "ur|startswith\("ur|er10l')


def test_arm_names_appear_only_in_the_robot_descriptions():
    hits = [
        f"{path.relative_to(ROOT)}:{n}"
        for path in sorted(ROOT.rglob("*.py"))
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if PATTERN.search(line)
    ]
    assert hits, "the pattern finds the descriptions themselves"
    assert all(hit.startswith("robots/") for hit in hits), hits
