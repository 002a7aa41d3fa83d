"""Start the simulator as a child process and steer its target: the measure loop's entry point.

::

    with SimulatorProcess(seed=7, initialised=True) as sim:
        tracker = LaserTracker(sim.url)           # the driver measures over the pty
        sim.set_target([2500.0, 300.0, -200.0])   # the simulated robot says where the target is
        ...

The driver gets the pty (``url``); target updates and faults go over a
separate loopback TCP connection (``control_url``) with the simulator-only
``SIM,...`` commands, so they never interleave with the driver's frames.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import serial
from numpy.typing import ArrayLike

from drivers.tracker.line.link import Link, close_for_good
from drivers.tracker.line.protocol import format_number

CONTROL_TIMEOUT_S = 5.0  # control replies are immediate; generous for loaded machines


def spawn(module: str, args: list[str]) -> subprocess.Popen[str]:
    """``python -m module args`` as a child in a session of its own, stdout piped (text).

    A terminal's Ctrl-C goes to its whole foreground process group: a
    simulator in the caller's group would die with it while the command is
    still finishing the pose in hand, and the run would end "tracker
    unavailable" instead of stopping cleanly. In its own session the child
    is stopped only by :meth:`SimulatorProcess.stop` (or when its pipe closes).
    """
    return subprocess.Popen(
        [sys.executable, "-m", module, *args],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )


class SimulatorControl:
    """Client for the simulator-only commands over any pyserial URL.

    Parameters
    ----------
    url : str
        Usually ``socket://127.0.0.1:PORT`` of a running simulator.
    """

    def __init__(self, url: str) -> None:
        self._port = serial.serial_for_url(url, timeout=CONTROL_TIMEOUT_S)
        self._link = Link(self._port)

    def set_target(self, point_mm: ArrayLike, rotvec_rad: ArrayLike | None = None) -> None:
        """``SIM,TARGET``: true target position (shape (3,), mm, tracker frame), optional
        probe rotation vector (shape (3,), rad)."""
        values = np.asarray(point_mm, dtype=float).reshape(3).tolist()
        if rotvec_rad is not None:
            values += np.asarray(rotvec_rad, dtype=float).reshape(3).tolist()
        # 6 decimals: below the 0.1 um / 10 nrad the tracker reports, so no visible rounding.
        args = [format_number(v, 6) for v in values]
        self._link.transact("SIM", "TARGET", *args, timeout_s=CONTROL_TIMEOUT_S)

    def clear_target(self) -> None:
        """``SIM,NOTARGET``: nothing for the beam to lock on."""
        self._link.transact("SIM", "NOTARGET", timeout_s=CONTROL_TIMEOUT_S)

    def run_path(
        self,
        t_s: ArrayLike,
        point_mm: ArrayLike,
        rotvec_rad: ArrayLike | None = None,
        delay_s: float = 0.0,
    ) -> int:
        """``SIM,PATH``: move the target through waypoints, starting ``delay_s`` from now.

        Parameters
        ----------
        t_s : array_like, shape (W,)
            Waypoint times from the path's start, s, increasing.
        point_mm : array_like, shape (W, 3)
            Waypoints, tracker frame, mm (linear in between).
        rotvec_rad : array_like, shape (W, 3), optional
            Probe orientations (probe to tracker frame), rad.
        delay_s : float
            Start this long after the simulator receives ``GO``, s.

        Returns
        -------
        int
            The path's start on the tracker's clock, microseconds (the stamps
            of its readings run on the same clock).
        """
        t = np.asarray(t_s, dtype=float).reshape(-1)
        values = np.asarray(point_mm, dtype=float).reshape(len(t), 3)
        if rotvec_rad is not None:
            values = np.hstack([values, np.asarray(rotvec_rad, dtype=float).reshape(len(t), 3)])
        self._link.transact("SIM", "PATH", "CLEAR", timeout_s=CONTROL_TIMEOUT_S)
        for ti, row in zip(t, values, strict=True):
            args = [format_number(ti, 6), *(format_number(v, 6) for v in row)]
            self._link.transact("SIM", "PATH", "POINT", *args, timeout_s=CONTROL_TIMEOUT_S)
        reply = self._link.transact(
            "SIM", "PATH", "GO", format_number(delay_s, 6), timeout_s=CONTROL_TIMEOUT_S
        )
        return int(reply.fields[0])

    def arm_fault(self, line: str) -> None:
        """``SIM,FAULT``: arm one fault-script line, e.g. ``"MEAS+1 beam_break"``."""
        self._link.transact("SIM", "FAULT", line, timeout_s=CONTROL_TIMEOUT_S)

    def close(self) -> None:
        """Close the control link (at once: it is never reopened)."""
        close_for_good(self._port)


class SimulatorProcess:
    """``python -m drivers.tracker.line.simulator --pty --tcp 0`` as a child process.

    Parameters
    ----------
    seed : int
        Noise seed.
    noise : bool
        False for exact readings.
    probe_6dof : bool
        Readings carry orientation.
    initialised : bool
        Start initialised (otherwise the caller must ``initialise()``).
    init_time_s : float
        Duration of ``INIT``.
    faults : str or Path, optional
        Fault script file.
    replay : str or Path, optional
        Recorded log to answer from instead of simulating.
    air : tuple of float, optional
        Air the station's sensors measure (``COND?``): degC, hPa, %RH.
    on_s : float, optional
        Time since power-on at start, s (``COND?``).
    latency_s : float
        How late its stamps are for a moving target, s (``--latency``).
    """

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: bool = True,
        probe_6dof: bool = False,
        initialised: bool = False,
        init_time_s: float = 0.2,
        faults: str | Path | None = None,
        replay: str | Path | None = None,
        air: tuple[float, float, float] | None = None,
        on_s: float | None = None,
        latency_s: float = 0.0,
    ):
        args = ["--pty", "--tcp", "0", "--seed", str(seed), "--init-time", str(init_time_s)]
        args += ["--latency", repr(float(latency_s))] if latency_s else []
        args += ["--air", ",".join(format_number(v, 4) for v in air)] if air else []
        args += ["--on-time", repr(float(on_s))] if on_s is not None else []
        args += [] if noise else ["--no-noise"]
        args += ["--probe-6dof"] if probe_6dof else []
        args += ["--initialised"] if initialised else []
        args += ["--faults", str(faults)] if faults else []
        args += ["--replay", str(replay)] if replay else []
        self._proc = spawn("drivers.tracker.line.simulator", args)
        stdout = self._proc.stdout
        assert stdout is not None  # stdout=PIPE above
        path, port = (stdout.readline().strip() for _ in range(2))
        if not path or not port:
            self._proc.kill()
            raise RuntimeError("tracker simulator did not start")
        self.url = path
        """pty device path for the driver."""
        self.control_url = f"socket://127.0.0.1:{port}"
        """Loopback URL for simulator-only commands."""
        self._control: SimulatorControl | None = None

    @property
    def control(self) -> SimulatorControl:
        if self._control is None:
            self._control = SimulatorControl(self.control_url)
        return self._control

    def set_target(self, point_mm: ArrayLike, rotvec_rad: ArrayLike | None = None) -> None:
        """Tell the simulator the true target (mm, tracker frame; rad); see SimulatorControl."""
        self.control.set_target(point_mm, rotvec_rad)

    def clear_target(self) -> None:
        self.control.clear_target()

    def run_path(
        self,
        t_s: ArrayLike,
        point_mm: ArrayLike,
        rotvec_rad: ArrayLike | None = None,
        delay_s: float = 0.0,
    ) -> int:
        """Move the target through waypoints; see :meth:`SimulatorControl.run_path`."""
        return self.control.run_path(t_s, point_mm, rotvec_rad, delay_s)

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
        if self._proc.stdout is not None:  # always, with stdout=PIPE
            self._proc.stdout.close()

    def __enter__(self) -> SimulatorProcess:
        return self

    def __exit__(self, *exc) -> None:
        self.stop()
