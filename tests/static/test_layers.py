"""Layer contracts: the CLI above the features, the features above the model, no cycles.

The import graph is built from the source with :mod:`ast`: every ``import``
and ``from ... import`` anywhere in a module counts (inside functions, under
``if TYPE_CHECKING:``, in ``try:``), relative imports resolved, so a lazy
import cannot hide a dependency. ``from pkg import name`` is an edge to the
module ``pkg.name`` when there is one, else to ``pkg`` itself.

A module belongs to the layer of its top-level name (``calibrator.cell.checks``
to the layer of ``calibrator.cell``; ``drivers.robot.ur.simulator`` to that of
``drivers``), so a module moved inside a package needs no edit here, and a
new top-level name needs one line in :data:`LAYERS`. The contracts:

- no cycle between modules, and none between top-level names (packages);
- a module imports only modules of its own layer or of layers below it;
- ``calibrator`` imports ``drivers`` only from the CLI (the hexagonal core:
  :mod:`calibrator.acquire.ports` is what devices implement);
- procedures above methods: a procedure module (:data:`PROCEDURES`: the cell
  sequence, the ``measure``, ``verify`` and ``check`` procedures built on it,
  the path and circle tests) is imported only by the CLI and other
  procedures, and no method module
  (:data:`METHODS`: identification, the model, planning, the figures and
  verdicts of verify and check) reaches one, even through other modules;
- only the CLI, the drivers and the simulation itself import the simulation
  (:data:`SIMULATION`): a procedure opens the simulated cell as devices, and
  neither the procedures nor the port and run under them nor the path tests'
  methods (:data:`WORLDLESS`) name a simulated world, even untyped (:data:`WORLD_NAMES`).

Each failure prints what breaks the contract and, for a cycle, its edges.
``python tests/static/test_layers.py`` prints the whole graph by layer.
"""

from __future__ import annotations

import ast
import functools
import sys
from collections.abc import Iterable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("calibrator", "drivers")

#: The layers, top to bottom, and the top-level names in each. A module may
#: import its own layer and the layers below. Edit this table when a
#: top-level name comes, goes or moves.
LAYERS: dict[str, tuple[str, ...]] = {
    # The command line: parses, wires drivers to the domain, prints.
    "cli": ("calibrator.cli", "calibrator.__main__"),
    # Hardware adapters and simulators behind the ports of calibrator.acquire.
    "drivers": ("drivers",),
    # What a user does: plan, measure, identify, export, compensate, check, ...
    "features": (
        "calibrator.acquire",
        "calibrator.analysis",
        "calibrator.cell",
        "calibrator.check",
        "calibrator.compensate",
        "calibrator.export",
        "calibrator.languages",
        "calibrator.history",
        "calibrator.identify",
        "calibrator.planning",
        "calibrator.report",
        "calibrator.simulate",
        "calibrator.verify",
        "calibrator.world",
    ),
    # The arm and its documents: kinematics, parameters, descriptions,
    # sessions, calibrations.
    "model": (
        "calibrator.calibration",
        "calibrator.fit_records",
        "calibrator.model",
        "calibrator.recorded_options",
        "calibrator.robots",
        "calibrator.session",
    ),
    # What every reader of user input uses: the strict grammar of numbers,
    # JSON and YAML, budgets, and the checks of what documents hold.
    "inputs": ("calibrator.inputs",),
    # Plain building blocks with no knowledge of the arm's documents.
    "base": ("calibrator", "calibrator.errors", "calibrator.halton", "calibrator.outputs"),
}

#: Only these may import ``drivers``.
DRIVER_USERS = ("calibrator.cli",)

#: The procedure modules: the one cell sequence and the procedures built on it.
PROCEDURES = (
    "calibrator.acquire.procedure",
    "calibrator.acquire.measure",
    "calibrator.check.procedure",
    "calibrator.check.circle_procedure",
    "calibrator.verify.procedure",
    "calibrator.verify.path_procedure",
)

#: Who may import a procedure module (besides the procedures themselves).
PROCEDURE_USERS = ("calibrator.cli",)

#: The method modules (``pkg.*``: every module under ``pkg``; the procedure
#: modules excepted): what a procedure uses, never what uses a procedure.
METHODS = (
    "calibrator.identify.*",
    "calibrator.model.*",
    "calibrator.planning.*",
    "calibrator.robots.*",
    "calibrator.check.*",
    "calibrator.verify.*",
)

#: The simulation: the simulated cell's hidden true arm and its world files.
SIMULATION = ("calibrator.simulate", "calibrator.world")

#: Who may import the simulation (besides the simulation itself).
SIMULATION_USERS = ("calibrator.cli", "drivers")

#: The path tests' methods: the robot runs the path (``FOLLOW_PATH``) and the
#: tracker streams it, so the true path comes from the devices, not a world.
PATH_METHODS = ("calibrator.verify.path", "calibrator.check.circle")

#: The port every procedure opens its devices through and the run it drives
#: them with: like the procedures, they carry no simulated world (no
#: parameter, field, attribute or name of :data:`WORLD_NAMES`); what a
#: procedure needs of the simulated cell comes as plain data in
#: ``calibrator.acquire.ports.Opened``.
WORLDLESS = PROCEDURES + ("calibrator.acquire.ports", "calibrator.acquire.run") + PATH_METHODS

#: What the simulated world and its wiring were called in a run.
WORLD_NAMES = frozenset({"world", "steer", "is_sim", "sim_world", "SimWorld"})

#: Imports that break a contract today, each with the change that removes it:
#: ``(importer, imported)``, module names, ``pkg.*`` for every module under
#: ``pkg``. The contracts are checked on the graph without these edges, and
#: an entry that no longer matches an import fails the test (delete it).
KNOWN: dict[tuple[str, str], str] = {}


def _matches(name: str, pattern: str) -> bool:
    if pattern.endswith(".*"):  # the package and every module under it
        return name == pattern[:-2] or name.startswith(pattern[:-1])
    return name == pattern


def _known(importer: str, imported: str) -> bool:
    return any(_matches(importer, a) and _matches(imported, b) for a, b in KNOWN)


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Every module of :data:`PACKAGES` by dotted name (a package by its ``__init__.py``)."""
    found = {}
    for package in PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            found[".".join(parts)] = path
    return found


def imports(name: str, path: Path, known: Iterable[str]) -> set[str]:
    """The modules of ``known`` that module ``name`` (file ``path``) imports, anywhere in it."""
    known = set(known)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                targets.append(sub if sub in known else source)
        for target in targets:
            while target and target not in known:  # "a.b.C" (a class) -> "a.b"
                target = target.rpartition(".")[0]
            # Every module "imports" the root package; that is not a dependency.
            if target and target != name and target not in PACKAGES:
                out.add(target)
    return out


def graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the modules it imports, over :data:`PACKAGES`."""
    return {name: set(targets) for name, targets in _parsed(root).items()}


@functools.cache
def _parsed(root: Path) -> dict[str, frozenset[str]]:
    # Parsed once per run: every test reads the same tree.
    found = modules(root)
    return {name: frozenset(imports(name, path, found)) for name, path in found.items()}


def checked_graph() -> dict[str, set[str]]:
    """:func:`graph` without the imports :data:`KNOWN` lists."""
    return {a: {b for b in targets if not _known(a, b)} for a, targets in graph().items()}


def top(name: str) -> str:
    """The top-level name of a module: ``calibrator.cell.checks`` -> ``calibrator.cell``."""
    parts = name.split(".")
    return ".".join(parts[:2]) if parts[0] == "calibrator" else parts[0]


def package_graph(edges: dict[str, set[str]]) -> dict[str, set[str]]:
    """Top-level name -> the other top-level names its modules import."""
    out: dict[str, set[str]] = {}
    for name, targets in edges.items():
        out.setdefault(top(name), set()).update(top(t) for t in targets if top(t) != top(name))
    return out


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def layer_of(name: str) -> str | None:
    """The layer of a module's top-level name, or None when :data:`LAYERS` does not list it."""
    for layer, names in LAYERS.items():
        if top(name) in names:
            return layer
    return None


def _describe(component: list[str], edges: dict[str, set[str]]) -> str:
    members = set(component)
    lines = [f"  {a} -> {b}" for a in component for b in sorted(edges.get(a, set()) & members)]
    return "cycle of " + ", ".join(component) + ":\n" + "\n".join(lines)


def test_every_top_level_name_has_a_layer():
    names = sorted({top(name) for name in modules()})
    missing = [name for name in names if layer_of(name) is None]
    assert not missing, "add these to LAYERS in tests/static/test_layers.py: " + ", ".join(missing)


def test_no_cycle_between_modules():
    edges = checked_graph()
    found = [_describe(c, edges) for c in cycles(edges)]
    assert not found, "import cycles between modules:\n" + "\n\n".join(found)


def test_no_cycle_between_packages():
    edges = package_graph(checked_graph())
    found = [_describe(c, edges) for c in cycles(edges)]
    assert not found, "import cycles between packages:\n" + "\n\n".join(found)


def test_every_known_exception_is_still_needed():
    # An entry for an import that is gone would let it come back unnoticed.
    edges = graph()
    stale = [
        f"  {a} -> {b}"
        for a, b in KNOWN
        if not any(_matches(m, a) and any(_matches(t, b) for t in ts) for m, ts in edges.items())
    ]
    assert not stale, "remove from KNOWN in tests/static/test_layers.py:\n" + "\n".join(stale)


def upward_imports(edges: dict[str, set[str]]) -> list[tuple[str, str, str]]:
    """``(module, imported, why)`` for every import of a higher layer."""
    rank = {layer: i for i, layer in enumerate(LAYERS)}
    out = []
    for name, targets in sorted(edges.items()):
        mine = layer_of(name)
        for target in sorted(targets):
            theirs = layer_of(target)
            if mine is None or theirs is None or rank[theirs] >= rank[mine]:
                continue
            out.append((name, target, f"{mine} imports {theirs}"))
    return out


def test_no_layer_imports_a_layer_above_it():
    found = [
        f"  {name} -> {target} ({why})" for name, target, why in upward_imports(checked_graph())
    ]
    order = " > ".join(LAYERS)
    assert not found, f"imports against the layers ({order}):\n" + "\n".join(found)


def test_only_the_cli_imports_drivers():
    found = [
        f"  {name} -> {target}"
        for name, targets in sorted(graph().items())
        if name.startswith("calibrator") and not name.startswith(DRIVER_USERS)
        for target in sorted(targets)
        if target.split(".")[0] == "drivers"
    ]
    assert not found, "calibrator imports drivers outside the CLI:\n" + "\n".join(found)


def test_every_procedure_and_simulation_module_exists():
    # A renamed module would leave its contract guarding nothing.
    found = modules()
    missing = [name for name in PROCEDURES + SIMULATION if name not in found]
    assert not missing, "update tests/static/test_layers.py, gone: " + ", ".join(missing)


def _is_method(name: str) -> bool:
    return name not in PROCEDURES and any(_matches(name, m) for m in METHODS)


def reaches(edges: dict[str, set[str]], start: str, targets: Iterable[str]) -> list[str] | None:
    """An import chain from ``start`` to a module of ``targets``, or None (breadth first)."""
    goal = set(targets)
    before: dict[str, str] = {start: ""}
    frontier = [start]
    while frontier:
        following = []
        for name in frontier:
            for target in sorted(edges.get(name, ())):
                if target in before:
                    continue
                before[target] = name
                if target in goal:
                    chain = [target]
                    while chain[-1] != start:
                        chain.append(before[chain[-1]])
                    return chain[::-1]
                following.append(target)
        frontier = following
    return None


def test_procedures_are_imported_only_by_the_cli_and_procedures():
    found = [
        f"  {name} -> {target}"
        for name, targets in sorted(checked_graph().items())
        if name not in PROCEDURES and not name.startswith(PROCEDURE_USERS)
        for target in sorted(targets)
        if target in PROCEDURES
    ]
    assert not found, "procedure modules imported below the CLI:\n" + "\n".join(found)


def test_no_method_reaches_a_procedure():
    edges = checked_graph()
    found = []
    for name in sorted(edges):
        if _is_method(name):
            chain = reaches(edges, name, PROCEDURES)
            if chain is not None:
                found.append("  " + " -> ".join(chain))
    assert not found, "methods that reach a procedure:\n" + "\n".join(found)


def test_only_the_cli_the_drivers_and_the_simulation_import_the_simulation():
    found = [
        f"  {name} -> {target}"
        for name, targets in sorted(checked_graph().items())
        if name not in SIMULATION and not name.startswith(SIMULATION_USERS)
        for target in sorted(targets)
        if target in SIMULATION
    ]
    assert not found, "the simulation imported outside the CLI and drivers:\n" + "\n".join(found)


def world_names(source: str) -> list[str]:
    """Where ``source`` names a simulated world: ``line: name`` for each parameter,
    keyword, attribute or name in :data:`WORLD_NAMES` (docstrings and comments aside)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        name = None
        if isinstance(node, ast.arg | ast.keyword):
            name = node.arg
        elif isinstance(node, ast.Attribute):
            name = node.attr
        elif isinstance(node, ast.Name):
            name = node.id
        if name in WORLD_NAMES:
            found.append(f"{node.lineno}: {name}")  # type: ignore[union-attr]
    return found


def test_the_procedures_and_their_port_and_run_name_no_simulated_world():
    found = modules()
    named = [
        f"  {module} line {where}"
        for module in WORLDLESS
        for where in world_names(found[module].read_text(encoding="utf-8"))
    ]
    assert not named, "a simulated world named where devices are opened by URL:\n" + "\n".join(
        named
    )


def test_the_new_contracts_catch_what_they_forbid():
    # Each contract on a made-up graph holding the import it forbids.
    edges = {
        "calibrator.planning.poses": {"calibrator.check.explain"},
        "calibrator.check.explain": {"calibrator.check.procedure"},
        "calibrator.check.procedure": {"calibrator.acquire.procedure"},
        "calibrator.acquire.run": {"calibrator.simulate"},
    }
    assert reaches(edges, "calibrator.planning.poses", PROCEDURES) == [
        "calibrator.planning.poses",
        "calibrator.check.explain",
        "calibrator.check.procedure",
    ]
    assert _is_method("calibrator.check.explain") and not _is_method("calibrator.check.procedure")
    assert reaches(edges, "calibrator.check.procedure", ["calibrator.simulate"]) is None
    # The world by any of its names, typed or not; a docstring saying "world" is no use of one.
    source = (
        'def run(p, *, world=None):\n    """the world"""\n    m = MeasureRun(p, steer=f)\n'
        "    return m.world, is_sim(p)\n"
    )
    assert world_names(source) == ["1: world", "3: steer", "4: world", "4: is_sim"]
    assert world_names("def run(p, devices):\n    return devices.tracker_at_mm\n") == []
    assert _matches("calibrator.model", "calibrator.model.*")
    assert not _matches("calibrator.modelling", "calibrator.model.*")


def test_the_graph_sees_lazy_relative_and_type_only_imports(tmp_path):
    # The contracts are only as good as the graph: a made-up package with
    # each kind of import, and the edges they must give.
    pkg = tmp_path / "calibrator"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "low.py").write_text("X = 1\n")
    (pkg / "sub" / "__init__.py").write_text("from . import leaf\n")
    (pkg / "sub" / "leaf.py").write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from calibrator.high import H\n"
        "def f():\n    from ..low import X\n    import calibrator.high\n    return X\n"
    )
    (pkg / "high.py").write_text("from calibrator.sub.leaf import f\nfrom calibrator import low\n")
    edges = {
        name: imports(name, path, modules(tmp_path).keys())
        for name, path in modules(tmp_path).items()
        if name.startswith("calibrator")
    }
    assert edges["calibrator.sub"] == {"calibrator.sub.leaf"}
    assert edges["calibrator.sub.leaf"] == {"calibrator.low", "calibrator.high"}
    assert edges["calibrator.high"] == {"calibrator.sub.leaf", "calibrator.low"}
    assert cycles(edges) == [["calibrator.high", "calibrator.sub.leaf"]]
    assert package_graph(edges)["calibrator.high"] == {"calibrator.sub", "calibrator.low"}


if __name__ == "__main__":
    edges = graph()
    for layer in LAYERS:
        print(f"[{layer}]")
        for name in sorted(n for n in edges if layer_of(n) == layer):
            print(f"  {name} -> {', '.join(sorted(edges[name])) or '-'}")
    for found in (edges, package_graph(edges)):
        for component in cycles(found):
            print(_describe(component, found), file=sys.stderr)
