"""A cell without a robot link: a tracker simulator on TCP and the external-robot player.

Both simulators run :data:`TIME_SCALE` times faster than the wall clock
(``--time-scale``): the program's moves and dwells, and the tracker's clock
that stamps its readings. ``measure --robot external`` times its watching by
those stamps, so it runs as fast with its options at their real-time values.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

from cli_process_kit import child_env, start_cli
from timeout_kit import readline

from calibrator import planning

#: Simulated seconds per wall-clock second of both simulators.
TIME_SCALE = 10
#: Where the shared plan's reflector is on the flange, mm (14 mm from the default guess
#: 0,0,100, with which every run here measures).
TOOL_MM = (11.3, -6.8, 96.2)


def first_poses(plan_path: Path, n: int, out: Path) -> Path:
    """The first ``n`` measured poses of a plan (with their vias), written to ``out``.

    Written without the file's record of the arm, tracker and reflector it was
    made for, as an older plan file is: ``measure`` then keeps the default
    reflector guess (0,0,100), 14 mm from where the shared plan's reflector is.
    """
    plan = planning.read_plan(plan_path)
    planning.write_plan(out, planning.Plan(plan.q_rad[:n], plan.via_rad[:n]))
    return out


@contextmanager
def tracker_simulator(seed: int = 2, time_scale: float = TIME_SCALE):
    """``python -m drivers.tracker.line.simulator --tcp 0 --initialised``; yields its socket URL."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "drivers.tracker.line.simulator",
            "--tcp",
            "0",
            "--initialised",
            "--seed",
            str(seed),
            "--time-scale",
            str(time_scale),
        ],
        stdout=subprocess.PIPE,
        text=True,
        env=child_env(None),
    )
    try:
        port = readline(proc.stdout, what="the simulator's port").strip()
        assert port.isdigit(), port
        yield f"socket://127.0.0.1:{port}"
    finally:
        proc.terminate()
        proc.wait(timeout=10)
        proc.stdout.close()


def start_player(plan: Path, url: str, *args, cwd: Path) -> subprocess.Popen:
    """``python -m drivers.robot.external_sim`` playing ``plan`` on the simulator at ``url``.

    At :data:`TIME_SCALE`, the tracker simulator's pace (``args`` are in controller
    seconds). The program is loaded and waits for :func:`press_start` (``--wait-start``),
    so the player's own start-up, seconds of a loaded machine and ten times as many of
    the simulators' clocks, is over before the run sees anything.
    """
    player = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "drivers.robot.external_sim",
            "--plan",
            str(plan),
            "--control",
            url,
            "--time-scale",
            str(TIME_SCALE),
            "--wait-start",
            *map(str, args),
        ],
        cwd=cwd,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=child_env(None),
    )
    return player


def press_start(player: subprocess.Popen) -> None:
    """Start the loaded program (once the run watches); fails if the player did not load."""
    ready = readline(player.stdout, what="'ready'").strip()
    assert ready == "ready", (ready, player.stderr.read() if player.poll() is not None else "")
    player.stdin.write("\n")
    player.stdin.close()


class Watching:
    """``calibrator measure --robot external ARGS`` (or ``command``) in ``cwd``, watching.

    Made once the run says its cell-time estimate, the line it prints with
    its journal open, just before it starts watching: the operator starts
    the program then, so the run sees the program's first stop however long
    its own start took on a loaded machine.
    """

    def __init__(
        self, *args, cwd: Path, ready_s: float = 120.0, command: str = "measure", wait=True
    ):
        self.proc = start_cli(command, "--robot", "external", *args, cwd=cwd)
        self._stderr: list[str] = []
        self._ready = threading.Event()
        # stderr carries a line per stop decision: drained as it comes, never left to fill
        self._drain = threading.Thread(target=self._read_stderr, daemon=True)
        self._drain.start()
        # With -q there is no estimate line: the journal it opens just before says the same.
        args = [str(a) for a in args]
        self._journal = (
            Path(cwd) / (args[args.index("-o") + 1] + ".journal") if "-o" in args else None
        )
        self._quiet = "-q" in args or "--quiet" in args
        self._ready_s = ready_s
        if wait:
            self.wait_ready()

    def wait_ready(self) -> None:
        """Return once the run watches (``wait=False`` made it return at once)."""
        deadline = time.monotonic() + self._ready_s
        while not self._ready.wait(0.05):
            if self._quiet and self._journal is not None and self._journal.exists():
                break
            assert time.monotonic() < deadline, f"measure not watching after {self._ready_s} s"
        assert self.proc.poll() is None, self.result(0)

    def _read_stderr(self) -> None:
        for line in self.proc.stderr:
            self._stderr.append(line)
            if line.startswith("estimated cell time"):
                self._ready.set()
        self._ready.set()  # it ended before watching: the caller reports why

    def result(self, timeout: float) -> subprocess.CompletedProcess:
        """Wait for the run to end; its exit code and output, as :func:`cli_process_kit.run_cli`."""
        # stdout holds one line per pose: far below a pipe's capacity, read once at the end.
        code = self.proc.wait(timeout=timeout)
        stdout = self.proc.stdout.read()
        self.proc.stdout.close()
        self._drain.join(timeout=10)
        return subprocess.CompletedProcess(self.proc.args, code, stdout, "".join(self._stderr))
