"""Mutation scores per module and per package, from a mutmut run's results.

Reads the ``*.meta`` files mutmut 3 writes under ``mutants/`` and prints a
Markdown table: mutants, killed, survived, no tests, not yet checked, and the
score (killed over checked, "no tests" counting as not killed). Timeouts and
crashes of the test process count as killed, as mutmut counts them.

Usage::

    .venv/bin/python benchmarks/mutation_scores.py            # per package
    .venv/bin/python benchmarks/mutation_scores.py --modules  # per module
    .venv/bin/python benchmarks/mutation_scores.py --survivors calibrator.outputs

Several runs can be combined: the first ``--root`` is the reference (its
mutants are the ones counted); a later root's result for a mutant is used
when it is better (killed over survived over no tests over not checked) and
the mutated function's source hash is the same in both runs, so a result
only ever counts for the code it was measured on::

    .venv/bin/python benchmarks/mutation_scores.py --root mutants --root ../wtm3/mutants

Re-running named mutants (``mutmut run NAME...``) first clears their
results; ``--survived-before FILE`` (one mutant name per line, the survivors
handed to such a re-run) counts a mutant the re-run has not reached yet as
survived rather than as not checked, so an unfinished re-run cannot raise the
score.

Run it after ``mutmut run`` (see docs/mutation-testing.md).

The drivers are measured one module at a time, each against the fast tests
that exercise it: ``--prepare MODULE FOLDER`` copies the repository's tracked
files to ``FOLDER`` (outside the work tree) with ``[tool.mutmut]`` narrowed
to that module and its tests (``DRIVER_RUNS``); then, in ``FOLDER``::

    nice -n 15 ../path/.venv/bin/mutmut run --max-children 1 "drivers.robot.ur.device*"
"""

import argparse
import json
import re
import shutil
import subprocess
from collections import Counter, defaultdict
from pathlib import Path

#: mutmut's statuses that count as a kill (the test run failed, hung or crashed).
KILLED = {"killed", "timeout", "segfault", "caught by type check"}
RANK = {"killed": 3, "survived": 2, "no tests": 1, "other": 1, "unchecked": 0}


#: Per driver module: the tests that exercise it (fast ones; no real hardware,
#: no tests that start processes mutmut cannot trace) and how many mutants may
#: run at once. The UR adapter's tests share the fake controller's fixed
#: ports (a cross-process lock serialises them), so its mutants must run one
#: at a time; the others were measured one at a time too (2 shared cores) and
#: may run two at a time.
DRIVER_RUNS = {
    "drivers.robot.safety": (
        [
            "tests/robot/test_robot_safety.py",
            "tests/robot/test_robot_limits_margin.py",
            "tests/robot/test_safety_boundaries.py",
            "tests/robot/test_model_motion_ceiling.py",
            "tests/robot/test_robot_inputs.py",
            "tests/robot/sim/test_robot_simulated.py",
        ],
        1,
    ),
    "drivers.tracker.line.link": (
        [
            "tests/tracker/line/test_tracker_link_frames.py",
            "tests/tracker/line/test_tracker_faults.py",
            "tests/tracker/line/test_tracker_grammar.py",
            "tests/tracker/line/test_tracker_integrity.py",
            "tests/tracker/line/test_tracker_scripted.py",
            "tests/tracker/line/test_tracker_link_errors_and_close.py",
            "tests/tracker/line/test_tracker_link_write_bound.py",
            "tests/tracker/line/test_tracker_link_long_lines.py",
            "tests/tracker/line/test_tracker_link_reads.py",
            "tests/tracker/line/test_tracker_rfc2217.py",
        ],
        1,
    ),
    "drivers.robot.ur.device": (
        [
            "tests/robot/ur/test_robot_ur_rtde.py",
            "tests/robot/ur/test_robot_timestamp_stall.py",
            "tests/robot/ur/test_robot_fake_ur.py",
            "tests/robot/test_robot_interface.py",
            "tests/robot/ur/test_ur_stop_latch.py",
            "tests/robot/ur/test_ur_stop_seen_at_connect.py",
            "tests/robot/ur/test_ur_move_ended_short.py",
            "tests/robot/ur/test_ur_close_stops_script.py",
            "tests/robot/ur/test_ur_command_deadline.py",
            "tests/robot/ur/test_ur_clear_stale_program_state.py",
        ],
        1,
    ),
}


def prepare(module, folder):
    """Copy the tracked files to ``folder`` with ``[tool.mutmut]`` set for ``module``.

    Returns the ``mutmut run`` command to run in ``folder``.
    """
    tests, children = DRIVER_RUNS[module]
    repo = Path(__file__).resolve().parent.parent
    files = subprocess.run(
        ["git", "ls-files", "-z"], cwd=repo, check=True, capture_output=True, text=True
    ).stdout.split("\0")
    folder = Path(folder)
    for name in filter(None, files):
        if (repo / name).is_file():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(repo / name, folder / name)
    source = module.replace(".", "/") + ".py"
    config = "\n".join(
        [
            "[tool.mutmut]",
            f"source_paths = [{source!r}]".replace("'", '"'),
            "pytest_add_cli_args_test_selection = [" + ", ".join(f'"{t}"' for t in tests) + "]",
            'also_copy = ["fixtures/", "drivers/"]',
            # mutmut stops a mutant after (expected + 1) * 2 * this many CPU seconds
            # (default 15): a mutant stuck in a loop is a kill either way, found sooner.
            "timeout_multiplier = 5.0",
            "",
        ]
    )
    pyproject = folder / "pyproject.toml"
    text = pyproject.read_text()
    text = re.sub(r"\[tool\.mutmut\].*?(?=^\[|\Z)", config + "\n", text, flags=re.S | re.M)
    pyproject.write_text(text)
    return f'nice -n 15 mutmut run --max-children {children} "{module}*"'


def _module_and_function(key):
    """``pkg.mod.x_fn__mutmut_3`` -> (``pkg.mod``, ``x_fn``)."""
    head = key.rsplit("__mutmut_", 1)[0]
    for marker in (".x_", ".xǁ"):
        if marker in head:
            module, _, rest = head.partition(marker)
            return module, marker[1:] + rest
    return head, ""


def _run(root):
    """``{key: (exit_code, function_hash)}`` for every mutant under ``root``."""
    found = {}
    for meta in sorted(Path(root).rglob("*.py.meta")):
        data = json.loads(meta.read_text())
        hashes = data.get("hash_by_function_name", {})
        for key, code in data.get("exit_code_by_key", {}).items():
            found[key] = (code, hashes.get(_module_and_function(key)[1]))
    return found


def outcomes(roots, survived_before=frozenset()):
    """Yield ``(module, mutant, exit_code)`` for every mutant of ``roots[0]``.

    Later roots contribute a better result for the same mutant of the same
    function source; a mutant in ``survived_before`` that no run has checked
    since counts as survived (see the module docstring).
    """
    reference = _run(roots[0])
    others = [_run(root) for root in roots[1:]]
    for key, (code, digest) in reference.items():
        for other in others:
            other_code, other_digest = other.get(key, (None, None))
            if other_digest == digest and RANK[classify(other_code)] > RANK[classify(code)]:
                code = other_code
        if code is None and key in survived_before:
            code = 0
        yield _module_and_function(key)[0], key, code


def classify(code):
    """Our group of a mutmut exit code: killed, survived, no tests, unchecked or other."""
    from mutmut.stats import status_by_exit_code  # mutmut's own table of exit codes

    if code is None:
        return "unchecked"
    status = status_by_exit_code[code]
    if status in KILLED:
        return "killed"
    return status if status in ("survived", "no tests") else "other"


def table(groups):
    lines = [
        "| group | mutants | killed | survived | no tests | not checked | score |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    total = Counter()
    for name in sorted(groups):
        counts = groups[name]
        total.update(counts)
        lines.append(_row(f"`{name}`", counts))
    lines.append(_row("**all**", total))
    return "\n".join(lines)


def _row(name, counts):
    mutants = sum(counts.values())
    checked = mutants - counts["unchecked"]
    killed = counts["killed"]
    score = f"{100 * killed / checked:.1f} %" if checked else "-"
    return (
        f"| {name} | {mutants} | {killed} | {counts['survived']} | {counts['no tests']}"
        f" | {counts['unchecked']} | {score} |"
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--root", action="append", help="mutmut's work folder (repeatable; default mutants)"
    )
    parser.add_argument("--modules", action="store_true", help="one row per module")
    parser.add_argument(
        "--survived-before", metavar="FILE", help="survivors handed to an unfinished re-run"
    )
    parser.add_argument("--survivors", metavar="PREFIX", help="list surviving mutants")
    parser.add_argument(
        "--prepare",
        nargs=2,
        metavar=("MODULE", "FOLDER"),
        help=f"set up a one-module run of a driver ({', '.join(DRIVER_RUNS)})",
    )
    args = parser.parse_args(argv)
    if args.prepare:
        print(prepare(*args.prepare))
        return
    roots = args.root or ["mutants"]
    before = frozenset()
    if args.survived_before:
        before = frozenset(Path(args.survived_before).read_text().split())
    if args.survivors is not None:
        for module, key, code in outcomes(roots, before):
            if module.startswith(args.survivors) and classify(code) in ("survived", "no tests"):
                print(key, classify(code))
        return
    groups = defaultdict(Counter)
    for module, _key, code in outcomes(roots, before):
        if args.modules:
            name = module
        else:
            parts = module.split(".")
            # calibrator.identify.pso -> calibrator.identify; calibrator.session -> calibrator
            name = ".".join(parts[:2]) if len(parts) > 2 else parts[0]
        groups[name][classify(code)] += 1
    print(table(groups))


if __name__ == "__main__":
    main()
