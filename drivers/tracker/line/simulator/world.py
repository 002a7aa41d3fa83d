"""The ``sim`` tracker kind: the tracker simulator as a child process, steered by the world.

The driver is the product's line-protocol driver over the simulator's pty,
so the whole wire protocol runs; the simulated robot (or the caller) tells
the simulator where the probe of the simulated world really is
(:meth:`SimulatedTracker.set_target`, declared as the ``steer`` capability).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibrator.acquire import ports
from drivers import urls
from drivers.errors import DriverError
from drivers.tracker.base import Environment, OpenOptions
from drivers.tracker.errors import TrackerGone
from drivers.tracker.line.device import LaserTracker, Status
from drivers.tracker.line.simulator.launch import SimulatorProcess


class SimulatedTracker(LaserTracker):
    """The line-protocol driver talking to a simulator process it starts on :meth:`connect`.

    Parameters
    ----------
    seed : int
        Noise seed of the simulator (the world's seed).
    noise : bool
        False for exact readings.
    faults, replay : str or Path, optional
        Fault script, or a recorded exchange to answer from.
    record : str or Path, optional
        Log the raw exchange.
    probe_6dof : bool
        The probe reports its orientation too (``P6`` readings).
    air : tuple of 3 float, optional
        The air the tracker's station measures (degC, hPa, %RH).
    on_s : float, optional
        The tracker's time since power-on at start, s.
    latency_s : float
        How late its stamps are for a moving target, s (a reading stamped
        ``t`` shows the target where it was at ``t - latency_s``).
    """

    capabilities = frozenset({ports.INITIALISE, ports.STEER, ports.REPORTS_CONDITIONS})

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: bool = True,
        faults: str | Path | None = None,
        replay: str | Path | None = None,
        record: str | Path | None = None,
        probe_6dof: bool = False,
        air: tuple | None = None,
        on_s: float | None = None,
        latency_s: float = 0.0,
    ) -> None:
        # The pty path is known once started; standard air, as the line opener sends.
        super().__init__("sim://", record=record, environment=Environment())
        self._seed = seed
        self._noise = noise
        self._faults = faults
        self._replay = replay
        self._probe_6dof = probe_6dof
        self._air, self._on_s = air, on_s
        self._latency_s = float(latency_s)
        if replay is not None:  # conditions are no reading: a replay does not ask for them
            self.capabilities = self.capabilities - {ports.REPORTS_CONDITIONS}
        self._process: SimulatorProcess | None = None

    def connect(self, environment: Environment | None = None, mode: str | None = None) -> Status:
        """Start the simulator (initialised, as a tracker warmed up and homed), then connect."""
        if self._process is None:
            self._process = SimulatorProcess(
                seed=self._seed,
                noise=self._noise,
                probe_6dof=self._probe_6dof,
                initialised=True,
                faults=self._faults,
                replay=self._replay,
                air=self._air,
                on_s=self._on_s,
                latency_s=self._latency_s,
            )
            self._url = self._process.url
        return super().connect(environment, mode)

    def set_target(self, point_mm: np.ndarray, rotvec_rad: np.ndarray | None = None) -> None:
        """Where the reflector really is: shape (3,), mm, tracker frame; and how the probe
        is turned (probe to tracker frame, rotation vector, shape (3,), rad; a 6-DoF probe
        reports it).

        Raises
        ------
        TrackerGone
            The simulator process is gone (a :class:`~calibrator.acquire.ports.TrackerUnavailable`).
        """
        if self._process is None:
            raise TrackerGone("tracker simulator not started: call connect() first")
        try:
            self._process.set_target(point_mm, rotvec_rad)
        except (DriverError, OSError) as exc:
            raise TrackerGone(f"tracker simulator: {exc}") from exc

    def run_path(
        self,
        t_s: np.ndarray,
        point_mm: np.ndarray,
        delay_s: float = 0.0,
        rotvec_rad: np.ndarray | None = None,
    ) -> int:
        """Move the reflector along the arm's true path: waypoints at ``t_s`` (s from the
        start), shape (N, 3), mm, tracker frame, starting ``delay_s`` from now; with
        ``rotvec_rad`` (N, 3), rad, the probe turns through those orientations (probe to
        tracker frame; a 6-DoF probe streams them).

        Returns
        -------
        int
            The start on the tracker's clock, microseconds (the clock of the stream's stamps).

        Raises
        ------
        TrackerGone
            The simulator process is gone.
        """
        if self._process is None:
            raise TrackerGone("tracker simulator not started: call connect() first")
        try:
            return self._process.run_path(t_s, point_mm, rotvec_rad, delay_s=delay_s)
        except (DriverError, OSError) as exc:
            raise TrackerGone(f"tracker simulator: {exc}") from exc

    def close(self) -> None:
        """Close the link, then stop the simulator process."""
        super().close()
        if self._process is not None:
            self._process.stop()
            self._process = None


#: What ``sim://?...`` takes: the simulator is configured by its URL, as
#: pyserial's ``loop://?logging=debug``, not by fields of the generic options.
URL_PARAMS: dict = {
    "noise": ("on", "off"),  # off: exact readings
    "probe": ("3dof", "6dof"),  # 6dof: the probe reports its orientation too
    "faults": None,  # a fault script (drivers.tracker.instrument.faults)
    "replay": None,  # a recorded exchange to answer from
    "latency": None,  # s, 0 to 1: how late the stamps are for a moving target
}


def open_url(url: str, options: OpenOptions) -> SimulatedTracker:
    """The tracker registry's handler of ``sim`` and ``sim://?noise=off&probe=6dof&...``.

    Parameters
    ----------
    url : str
        ``sim`` (noise on, a 3-DoF reflector) or ``sim://?`` with any of
        ``noise=on|off``, ``probe=3dof|6dof``, ``faults=PATH``, ``replay=PATH``.
    options : OpenOptions
        ``world`` (required: its seed, air and power-on time), ``record``.

    Raises
    ------
    ValueError
        No world, or a malformed URL (an unknown parameter, a value it does not take).
    """
    params = urls.settings(url, "sim", URL_PARAMS)
    latency_s = _latency(params.get("latency", "0"))
    if options.world is None:
        raise ValueError("--tracker sim needs the simulated world (measure builds it)")
    return SimulatedTracker(
        seed=options.world.seed if options.world.noise_seed is None else options.world.noise_seed,
        noise=params.get("noise", "on") == "on",
        faults=params.get("faults"),
        replay=params.get("replay"),
        record=options.record,
        probe_6dof=params.get("probe") == "6dof",
        air=options.world.air,
        on_s=options.world.tracker_on_s,
        latency_s=latency_s,
    )


def _latency(text: str) -> float:
    """``latency=S`` read: seconds in 0..1; ValueError naming it otherwise."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0.0 <= value <= 1.0:  # NaN fails too
        raise ValueError(f"sim tracker latency={text!r}: seconds from 0 to 1")
    return value
