"""The ``emscon+sim`` tracker kind: the emScon simulator as a child process, steered by the world.

The simulated cell with a Leica tracker: the driver is the product's emScon
adapter (:class:`~drivers.tracker.emscon.device.EmsconTracker`) over
loopback TCP to ``python -m drivers.tracker.emscon.simulator``, so the whole
emScon wire runs (stationary readings, continuous time and distance modes,
6-DoF probe results). The simulator is the same simulated tracker as the
``sim`` kind's (:mod:`drivers.tracker.instrument`): the simulated robot
tells it where the probe truly is after each move (``set_target``, the
``steer`` capability) and runs a timed path on it (``run_path``, which the
path tests stream), through the control port's ``SIM,TARGET`` and
``SIM,PATH`` commands, the same as the line simulator's::

    calibrator verify --seed 3 --tracker emscon+sim --path circle -o c.json
    calibrator measure --tracker 'emscon+sim://?noise=off&probe=6dof' -o s.parquet
"""

from __future__ import annotations

from typing import Any

import numpy as np

from calibrator.acquire import ports
from drivers import urls
from drivers.errors import DriverError
from drivers.tracker.base import Environment, OpenOptions
from drivers.tracker.emscon.device import CAPABILITIES, EmsconStatus, EmsconTracker
from drivers.tracker.emscon.errors import TrackerGone
from drivers.tracker.emscon.simulator.launch import EmsconSimulatorProcess

#: The kind's URL scheme (``emscon+sim`` bare, or ``emscon+sim://?settings``).
SCHEME = "emscon+sim"


class SimulatedEmsconTracker(EmsconTracker):
    """The emScon adapter talking to an emScon simulator process it starts on :meth:`connect`.

    Parameters
    ----------
    seed : int
        Noise seed of the simulator (the world's seed).
    noise : bool
        False for exact readings.
    faults : str or Path, optional
        Fault script (the shared syntax, emScon commands counted under the line
        protocol's names).
    probe_6dof : bool
        A 6-DoF probe: ``ProbeStationaryResult`` and 6-DoF continuous results.
    air : tuple of 3 float, optional
        The air the tracker's weather station measures (degC, hPa, %RH).
    on_s : float, optional
        The tracker's time since power-on at start, s.
    latency_s : float
        How late continuous results' stamps are for a moving target, s.
    """

    capabilities = CAPABILITIES | {ports.STEER}

    def __init__(
        self,
        *,
        seed: int = 0,
        noise: bool = True,
        faults: str | None = None,
        probe_6dof: bool = False,
        air: tuple | None = None,
        on_s: float | None = None,
        latency_s: float = 0.0,
    ) -> None:
        # The port is known once started; standard air sent, as the line simulator's opener.
        super().__init__("127.0.0.1", 0, environment=Environment())
        self._settings: dict[str, Any] = {
            "seed": seed,
            "noise": noise,
            "faults": faults,
            "probe": probe_6dof,
            "air": air,
            "on_s": on_s,
            "latency_s": latency_s,
        }
        self._process: EmsconSimulatorProcess | None = None

    def connect(self) -> EmsconStatus:
        """Start the simulator (initialised, as a tracker warmed up and homed), then connect."""
        if self._process is None:
            self._process = EmsconSimulatorProcess(initialised=True, **self._settings)
            self.port = self._process.port
        return super().connect()

    def set_target(self, point_mm: np.ndarray, rotvec_rad: np.ndarray | None = None) -> None:
        """Where the reflector (or probe tip) really is: shape (3,), mm, tracker frame; the
        probe's orientation (probe to tracker frame, rotation vector, shape (3,), rad).

        Raises
        ------
        TrackerGone
            The simulator process is not started or gone.
        """
        try:
            self._running().set_target(point_mm, rotvec_rad)
        except (DriverError, OSError) as exc:
            raise TrackerGone(f"emScon simulator: {exc}") from exc

    def run_path(
        self,
        t_s: np.ndarray,
        point_mm: np.ndarray,
        delay_s: float = 0.0,
        *,
        rotvec_rad: np.ndarray | None = None,
    ) -> int:
        """Move the target along the arm's true path: waypoints at ``t_s`` (s from the
        start), shape (N, 3), mm, tracker frame, starting ``delay_s`` from now; and the
        probe's orientations, shape (N, 3), rad, if given (a 6-DoF stream carries them;
        without them the probe keeps the orientation it was last given).

        Returns
        -------
        int
            The start on the tracker's clock, microseconds (the clock of the
            continuous results' stamps).

        Raises
        ------
        TrackerGone
            The simulator process is not started or gone.
        """
        try:
            return self._running().run_path(t_s, point_mm, rotvec_rad, delay_s=delay_s)
        except (DriverError, OSError) as exc:
            raise TrackerGone(f"emScon simulator: {exc}") from exc

    def _running(self) -> EmsconSimulatorProcess:
        if self._process is None:
            raise TrackerGone("emScon simulator not started: call connect() first")
        return self._process

    def close(self) -> None:
        """Close the connection, then stop the simulator process."""
        super().close()
        if self._process is not None:
            self._process.stop()
            self._process = None


#: What ``emscon+sim://?...`` takes (the ``sim`` kind's settings an emScon server has).
URL_PARAMS: dict = {
    "noise": ("on", "off"),  # off: exact readings
    "probe": ("3dof", "6dof"),  # 6dof: a T-Probe's 6-DoF results
    "faults": None,  # a fault script (drivers.tracker.instrument.faults)
}


def open_url(url: str, options: OpenOptions) -> SimulatedEmsconTracker:
    """The tracker registry's handler of ``emscon+sim`` and ``emscon+sim://?noise=off&...``.

    Parameters
    ----------
    url : str
        ``emscon+sim`` (noise on, a reflector) or ``emscon+sim://?`` with any of
        ``noise=on|off``, ``probe=3dof|6dof``, ``faults=PATH``.
    options : OpenOptions
        ``world`` (required: its seed, air and power-on time).

    Raises
    ------
    ValueError
        No world, a recording asked for (emScon's exchange is not recorded), or a
        malformed URL (an unknown parameter, a value it does not take).
    """
    params = urls.settings(url, SCHEME, URL_PARAMS)
    if options.world is None:
        raise ValueError(f"--tracker {SCHEME} needs the simulated world (measure builds it)")
    if options.record is not None:
        raise ValueError(f"{url}: recording the exchange needs a line-protocol tracker (sim)")
    world = options.world
    return SimulatedEmsconTracker(
        seed=world.seed if world.noise_seed is None else world.noise_seed,
        noise=params.get("noise", "on") == "on",
        faults=params.get("faults"),
        probe_6dof=params.get("probe") == "6dof",
        air=world.air,
        on_s=world.tracker_on_s,
    )
