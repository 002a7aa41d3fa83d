"""The planning package's place among the packages: the plan type a leaf, no cycle with the cell.

Read from the source (every ``import`` statement, those under ``TYPE_CHECKING``
and inside functions included), so a lazy import cannot hide a cycle.
"""

import ast
from pathlib import Path

import calibrator

ROOT = Path(calibrator.__file__).parent


def imported(path):
    """Every ``calibrator`` module a file imports, by its dotted name."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
    return {n for n in names if n.split(".")[0] == "calibrator"}


def package_imports(package):
    return {n for path in (ROOT / package).rglob("*.py") for n in imported(path)}


def test_the_cell_imports_nothing_of_planning():
    assert not {n for n in package_imports("cell") if n.startswith("calibrator.planning")}


def test_planning_uses_the_cell_and_nothing_imports_the_old_module():
    assert "calibrator.cell" in package_imports("planning")
    assert not (ROOT / "plan.py").exists()
    everywhere = {n for path in ROOT.rglob("*.py") for n in imported(path)}
    assert "calibrator.plan" not in everywhere


def test_the_plan_type_is_a_leaf():
    assert imported(ROOT / "planning" / "plan.py") == {
        "calibrator.errors",
        "calibrator.errors.CalibrationError",
    }
