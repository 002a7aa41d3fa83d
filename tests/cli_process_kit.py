"""Running ``calibrator`` as a user does: a new process, its output and exit code."""

import os
import signal
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
    return subprocess.run(
        [sys.executable, "-m", "calibrator", *map(str, args)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        env=child_env(env),
        **kwargs,
    )


def start_cli(*args, cwd=None, own_group=False):
    """``python -m calibrator ARGS`` started in ``cwd`` and left running (text pipes).

    The child takes Ctrl-C as a terminal user's command does, even when the
    test run itself ignores SIGINT (started in the background by a
    non-interactive shell, or under ``nohup``), which children inherit and
    Python then leaves ignored. ``own_group``: the child leads a process group
    of its own, like a terminal's foreground job, so ``os.killpg(child.pid,
    SIGINT)`` is a terminal's Ctrl-C (it reaches the children it starts too).
    """
    return subprocess.Popen(
        [sys.executable, "-m", "calibrator", *map(str, args)],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(None),
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        start_new_session=own_group,
    )


def child_env(env=None):
    """The environment of a child ``calibrator``: this package copy first (see :func:`run_cli`)."""
    env = dict(os.environ if env is None else env)
    if env.get("MUTANT_UNDER_TEST") == "stats":
        del env["MUTANT_UNDER_TEST"]
    package_root = str(Path(calibrator.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [package_root, env.get("PYTHONPATH")]))
    return env
