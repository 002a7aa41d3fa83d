"""Run named mutmut mutants the way mutmut runs them: one warm process, a fork per mutant.

mutmut activates a mutant by the environment variable ``MUTANT_UNDER_TEST``
in a forked test process. On a heavily loaded machine its own run can spend
its whole time in its statistics phase; this runs a given list of mutants
(``benchmarks/mutation_sample.py``'s names) inside the ``mutants/`` folder
``mutmut run`` has generated, with the tests given, and writes one verdict a
line: ``NAME killed|survived|timeout|no-tests|errorN SECONDS``. A mutant is
killed when a test fails (pytest's exit code 1), survived when all pass.

Alembic loads a migration revision by its file path, as a module named
``NNNN_name_py``; its mutants are activated under that name, which makes
them reachable (under ``mutmut run`` they show as "no tests").

Usage, from inside ``mutants/`` with mutmut and the folder importable::

    python ../benchmarks/mutation_fork_run.py NAMES OUT 400 -- tests/history/ -k "not postgresql"
"""

from __future__ import annotations

import os
import re
import signal
import sys
import time

import pytest

#: pytest's exit codes as verdicts.
VERDICTS = {0: "survived", 1: "killed", 5: "no-tests"}


def activation_name(name: str) -> str:
    """The ``MUTANT_UNDER_TEST`` value of a mutant (a migration's by its Alembic module)."""
    m = re.match(r"calibrator\.history\.migrations\.versions\.(\d{4}_\w+?)\.(x_.*)", name)
    return f"{m[1]}_py.{m[2]}" if m else name


def run_one(name: str, args: list[str], limit_s: float) -> str:
    """The verdict of one mutant: its tests run in a forked child, killed past ``limit_s``."""
    start = time.monotonic()
    pid = os.fork()
    if pid == 0:  # the child: quiet, its own process group (so a timeout ends its children)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        os.environ["MUTANT_UNDER_TEST"] = activation_name(name)
        os.setpgid(0, 0)
        os._exit(int(pytest.main([*args, "-x", "-q", "-p", "no:cacheprovider", "-n", "0"])))
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            code = os.waitstatus_to_exitcode(status)
            return VERDICTS.get(code, f"error{code}")
        if time.monotonic() - start > limit_s:
            os.killpg(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return "timeout"
        time.sleep(0.2)


def main(argv: list[str]) -> None:
    names_file, out_file, limit_s = argv[0], argv[1], float(argv[2])
    args = argv[argv.index("--") + 1 :]
    # Import the tests and the code once, before forking.
    pytest.main([*args, "--collect-only", "-q", "-p", "no:cacheprovider", "-n", "0"])
    with open(names_file, encoding="utf-8") as names, open(out_file, "a", encoding="utf-8") as out:
        for name in names.read().split():
            start = time.monotonic()
            verdict = run_one(name, args, limit_s)
            out.write(f"{name} {verdict} {time.monotonic() - start:.1f}\n")
            out.flush()


if __name__ == "__main__":
    main(sys.argv[1:])
