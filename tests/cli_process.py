"""Running ``calibrator`` as a user does: a new process, its output and exit code."""

import os
import subprocess
import sys
from pathlib import Path

import calibrator


def run_cli(*args, cwd=None, timeout=120, env=None, **kwargs):
    """``python -m calibrator ARGS`` in ``cwd``; the completed process (text output).

    The child imports the same copy of the package as the test process: under
    mutation testing that copy is mutmut's mutated one (and the child inherits
    which mutant is active), so a command run this way can kill a mutant.
    While mutmut only records which functions the tests call ("stats"), the
    child runs unrecorded: mutmut's recorder cannot work outside its own
    process.
    """
    env = dict(os.environ if env is None else env)
    if env.get("MUTANT_UNDER_TEST") == "stats":
        del env["MUTANT_UNDER_TEST"]
    package_root = str(Path(calibrator.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [package_root, env.get("PYTHONPATH")]))
    return subprocess.run(
        [sys.executable, "-m", "calibrator", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        **kwargs,
    )
