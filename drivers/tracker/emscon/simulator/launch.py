"""Start the emScon simulator as a child process and steer its target, like ``SimulatorProcess``.

::

    with EmsconSimulatorProcess(seed=7, initialised=True) as sim:
        tracker = open_tracker(sim.url)          # emscon://127.0.0.1:PORT
        sim.set_target([2500.0, 300.0, -200.0])  # what the simulated robot calls
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from drivers.tracker.simulator.launch import SimulatorControl


class EmsconSimulatorProcess:
    """``python -m drivers.tracker.emscon.simulator`` as a child process.

    Parameters are those of :class:`~drivers.tracker.emscon.simulator.EmsconSimulator`;
    ``faults`` is a fault-script file.
    """

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: bool = True,
        initialised: bool = False,
        init_time_s: float = 0.2,
        faults: str | Path | None = None,
    ):
        args = ["--seed", str(seed), "--init-time", str(init_time_s)]
        args += [] if noise else ["--no-noise"]
        args += ["--initialised"] if initialised else []
        args += ["--faults", str(faults)] if faults else []
        self._proc = subprocess.Popen(
            [sys.executable, "-m", "drivers.tracker.emscon.simulator", *args],
            stdout=subprocess.PIPE,
            text=True,
        )
        port, control = (self._proc.stdout.readline().strip() for _ in range(2))
        if not port or not control:
            self._proc.kill()
            self._proc.wait()
            raise RuntimeError("emScon simulator did not start")
        self.port = int(port)
        self.url = f"emscon://127.0.0.1:{self.port}"
        """``emscon://`` URL for :func:`drivers.tracker.emscon.open_tracker`."""
        self.control_url = f"socket://127.0.0.1:{control}"
        """Loopback URL for the simulator-only ``SIM,...`` commands."""
        self._control: SimulatorControl | None = None

    @property
    def control(self) -> SimulatorControl:
        if self._control is None:
            self._control = SimulatorControl(self.control_url)
        return self._control

    def set_target(self, point_mm, rotvec_rad=None) -> None:
        """True target (mm, tracker frame); the orientation is ignored (reflectors only)."""
        self.control.set_target(point_mm, rotvec_rad)

    def clear_target(self) -> None:
        self.control.clear_target()

    def arm_fault(self, line: str) -> None:
        self.control.arm_fault(line)

    def stop(self) -> None:
        """Terminate the child and close the control link."""
        if self._control is not None:
            self._control.close()
            self._control = None
        if self._proc.poll() is None:
            self._proc.terminate()
            try:
                self._proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        self._proc.stdout.close()

    def __enter__(self) -> EmsconSimulatorProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()
