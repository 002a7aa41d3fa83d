"""Static checks: type hints on every public function, mypy and ruff clean.

mypy runs in basic mode as configured in pyproject.toml ([tool.mypy]); it
checks the bodies of annotated functions, so the two tests go together.
"""

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _unannotated(path: Path) -> list[str]:
    """Public functions and methods of ``path`` missing a parameter or return annotation."""
    missing = []

    def visit(node: ast.AST, prefix: str, public: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.ClassDef):
                visit(child, f"{prefix}{child.name}.", public and not child.name.startswith("_"))
            elif isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = child.name
                dunder = name.startswith("__") and name.endswith("__")
                if (
                    not public
                    or (name.startswith("_") and name != "__init__")
                    or (dunder and name != "__init__")
                ):
                    continue
                args = child.args
                params = [*args.posonlyargs, *args.args, *args.kwonlyargs]
                params = [a for a in params if a.arg not in ("self", "cls")]
                params += [a for a in (args.vararg, args.kwarg) if a is not None]
                returns_ok = child.returns is not None or name == "__init__"
                if not returns_ok or any(a.annotation is None for a in params):
                    missing.append(f"{path.relative_to(ROOT)}:{child.lineno} {prefix}{name}")

    visit(ast.parse(path.read_text(encoding="utf-8")), "", True)
    return missing


def test_every_public_function_has_type_hints():
    files = sorted((ROOT / "calibrator").rglob("*.py")) + sorted((ROOT / "drivers").rglob("*.py"))
    missing = [m for f in files for m in _unannotated(f)]
    assert not missing, f"{len(missing)} public functions without hints:\n" + "\n".join(missing)


def test_mypy_is_clean():
    done = subprocess.run(
        [sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-2000:]


def test_ruff_is_clean():
    for args in (["check", "."], ["format", "--check", "."]):
        done = subprocess.run(
            [sys.executable, "-m", "ruff", *args],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-2000:]
