"""Start the emScon simulator as a child process and steer its target, like ``SimulatorProcess``.

::

    with EmsconSimulatorProcess(seed=7, initialised=True) as sim:
        tracker = open_tracker(sim.url)          # emscon://127.0.0.1:PORT
        sim.set_target([2500.0, 300.0, -200.0])  # what the simulated robot calls
"""

from __future__ import annotations

from pathlib import Path

from drivers.tracker.line.protocol import format_number
from drivers.tracker.line.simulator.launch import SimulatorProcess, spawn


class EmsconSimulatorProcess(SimulatorProcess):
    """``python -m drivers.tracker.emscon.simulator`` as a child process.

    Parameters are those of :class:`~drivers.tracker.emscon.simulator.EmsconSimulator`;
    ``faults`` is a fault-script file; ``air`` a weather station's air (degC, hPa,
    %RH), ``on_s`` the time since power-on at start, s. Steering (``set_target``, ``clear_target``,
    ``arm_fault``, ``control``) and ``stop`` are :class:`SimulatorProcess`'s: the
    control port speaks the same ``SIM,...`` commands. ``set_target``'s orientation
    is ignored (reflectors only).
    """

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: bool = True,
        initialised: bool = False,
        init_time_s: float = 0.2,
        faults: str | Path | None = None,
        ack_start: bool = False,
        probe: bool = False,
        latency_s: float = 0.0,
        air: tuple[float, float, float] | None = None,
        on_s: float | None = None,
        time_scale: float = 1.0,
    ):  # replaces SimulatorProcess.__init__: another program, two endpoint lines
        args = ["--seed", str(seed), "--init-time", str(init_time_s)]
        args += ["--ack-start"] if ack_start else []
        args += ["--probe"] if probe else []
        args += ["--latency", repr(float(latency_s))] if latency_s else []
        args += [] if noise else ["--no-noise"]
        args += ["--initialised"] if initialised else []
        args += ["--faults", str(faults)] if faults else []
        args += ["--air", ",".join(format_number(v, 4) for v in air)] if air is not None else []
        args += ["--on-time", repr(float(on_s))] if on_s is not None else []
        args += ["--time-scale", repr(float(time_scale))] if time_scale != 1.0 else []
        self._proc = spawn("drivers.tracker.emscon.simulator", args)
        stdout = self._proc.stdout
        assert stdout is not None  # stdout=PIPE above
        port, control = (stdout.readline().strip() for _ in range(2))
        if not port or not control:
            self._proc.kill()
            self._proc.wait()
            raise RuntimeError("emScon simulator did not start")
        self.port = int(port)
        self.url = f"emscon://127.0.0.1:{self.port}"
        """``emscon://`` URL for :func:`drivers.tracker.emscon.open_tracker`."""
        self.control_url = f"socket://127.0.0.1:{control}"
        """Loopback URL for the simulator-only ``SIM,...`` commands."""
        self._control = None
