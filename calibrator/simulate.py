"""Synthetic sessions from a "true" arm with known errors.

The true arm is a named model plus MDH errors, a base frame somewhere in
front of the tracker and a tool; the session records what a tracker would
see of it, and the truth is written beside the session so tests and users
can check what ``identify`` recovers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from datetime import UTC, datetime, timedelta
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator import robots
from calibrator.model import DEFAULT_TOOL_MM, frames, kinematics, parameters, rotations
from calibrator.model.noise import TRACKER_NOISE
from calibrator.robots import ipso_paper

if TYPE_CHECKING:
    import pyarrow as pa

    from calibrator.session import SessionMeta


#: The IPSO paper, Table 2: the errors injected into the ER10L-C10 (a, alpha, theta, d, beta).
IPSO_PAPER_ERRORS = np.array(ipso_paper.TABLE_2_ERRORS)


@dataclass(frozen=True)
class Truth:
    """The true arm behind a simulated session.

    Attributes
    ----------
    mdh : ndarray, shape (6, 5)
    base2tracker : ndarray, shape (4, 4)
    flange2tool : ndarray, shape (4, 4)
    """

    mdh: np.ndarray
    base2tracker: np.ndarray
    flange2tool: np.ndarray

    def to_json(self) -> dict:
        return {
            k: np.asarray(getattr(self, k)).tolist() for k in ("mdh", "base2tracker", "flange2tool")
        }


#: The simulated measuring cell: where the tracker stands in the robot base frame
#: (mm) and how it is turned (rotation vector, rad); roughly what a user would measure.
SIM_TRACKER_AT_MM = np.array([2500.0, 400.0, 300.0])
SIM_TRACKER_ROTVEC = np.array([0.05, -0.1, 2.8])

#: How well the simulated cell's base frame is surveyed: standard deviation of
#: each translation (mm) and rotation (rad) component, a tracker on base fiducials.
SIM_SURVEY_MM, SIM_SURVEY_RAD = 0.02, 20e-6


@dataclass(frozen=True)
class SimWorld:
    """The one simulated world behind ``measure --robot sim`` / ``--tracker sim`` (seeded).

    The simulated robot moves this true arm, and the tracker simulator is
    told where this arm's probe really is; nothing else holds a truth.

    Attributes
    ----------
    model : calibrator.robots.RobotDescription
        The nominal arm (what the session says it measured).
    seed : int
    true_mdh : ndarray, shape (6, 5)
        Nominal plus hidden errors (+-0.5 mm, +-1 mrad), mm and rad.
    base2tracker : ndarray, shape (4, 4)
        Robot base in the tracker frame, mm.
    flange2tool : ndarray, shape (4, 4)
        The true tool: :data:`calibrator.model.DEFAULT_TOOL_MM` plus an
        unknown 1.5 mm error.
    tracker_at_mm : ndarray, shape (3,)
        The tracker's position in the robot base frame (plans use it).
    repeatability : drivers.robot.sim.device.JointRepeatability, optional
        The true arm's load-side joint errors (positioning spread, backlash);
        None: it lands exactly where commanded. Drawn from
        :meth:`repeatability_rng`.
    noise_seed : int, optional
        Seed of the trackers' noise; None: ``seed``. A world file pins the
        arm's seed and leaves each run's noise to the run's own seed.
    air : tuple of 3 float, optional
        The air around the tracker: degC, hPa, %RH (None: the simulator's
        standard air).
    tracker_on_s : float, optional
        The tracker's time since power-on when the run starts, s (None: the
        simulator's default, warmed up).
    """

    model: robots.RobotDescription
    seed: int
    true_mdh: np.ndarray
    base2tracker: np.ndarray
    flange2tool: np.ndarray
    tracker_at_mm: np.ndarray
    # drivers.robot.sim.device.JointRepeatability (the drivers' type: not imported here).
    repeatability: Any = None
    noise_seed: int | None = None
    air: tuple | None = None
    tracker_on_s: float | None = None

    @classmethod
    def make(cls, model_name: str, seed: int, repeatability: object = None) -> SimWorld:
        """The world of ``model_name`` (a named model) drawn from ``seed``.

        ``repeatability`` (a ``JointRepeatability``) gives the arm its joint
        errors; it draws from its own stream, so the hidden arm is the same
        with or without it.
        """
        model = robots.get(model_name)
        rng = np.random.default_rng(seed)
        true_mdh = model.mdh + random_errors(model.mdh, rng, mm=0.5, rad=1e-3)
        offset = rng.standard_normal(3)
        offset *= 1.5 / np.linalg.norm(offset)  # an unknown 1.5 mm error of the tool point
        tool = frames.transform(translation=np.add(DEFAULT_TOOL_MM, offset))
        tracker2base = frames.transform(
            rotations.rotvec_to_matrix(SIM_TRACKER_ROTVEC), SIM_TRACKER_AT_MM
        )
        return cls(
            model,
            seed,
            true_mdh,
            frames.invert(tracker2base),
            tool,
            SIM_TRACKER_AT_MM.copy(),
            repeatability,
        )

    def with_tracker_at(self, at_mm: ArrayLike) -> SimWorld:
        """This world with the tracker moved to ``at_mm`` (3,), robot base frame, mm.

        The tracker is shifted by ``at_mm - tracker_at_mm`` and keeps its
        orientation, so anything else the world holds between base and
        tracker (a base that moved: :mod:`calibrator.world`) stays; the arm,
        tool and seed are unchanged.
        """
        at = np.asarray(at_mm, dtype=float).reshape(3)
        shift = frames.transform(translation=at - np.asarray(self.tracker_at_mm, dtype=float))
        tracker2base = shift @ frames.invert(self.base2tracker)
        return replace(self, base2tracker=frames.invert(tracker2base), tracker_at_mm=at.copy())

    def repeatability_rng(self) -> np.random.Generator:
        """The generator of the arm's joint errors: its own stream of the world's seed."""
        return np.random.default_rng([self.seed, 9283])

    def surveyed_base2tracker(self) -> np.ndarray:
        """The base frame as a user would survey it: the truth plus a seeded survey error.

        Returns
        -------
        ndarray, shape (4, 4)
            Robot base in the tracker frame, mm: ``base2tracker`` moved by an
            error of :data:`SIM_SURVEY_MM` (each translation component, mm) and
            :data:`SIM_SURVEY_RAD` (each rotation component, rad), drawn from
            the world's seed (a tracker on base fiducials).
        """
        rng = np.random.default_rng([self.seed, 9283, 1])
        error = frames.transform(
            rotations.rotvec_to_matrix(rng.normal(0.0, SIM_SURVEY_RAD, 3)),
            rng.normal(0.0, SIM_SURVEY_MM, 3),
        )
        return np.asarray(self.base2tracker @ error, float)

    def tool_pose(self, q_rad: ArrayLike) -> np.ndarray:
        """True probe pose in the tracker frame for joints ``q_rad`` (6,), shape (4, 4), mm."""
        return kinematics.forward(
            self.true_mdh, np.asarray(q_rad, float)[None], self.flange2tool, self.base2tracker
        )[0]


def random_errors(
    nominal_mdh: np.ndarray, rng: np.random.Generator, mm: float = 0.5, rad: float = 0.01
) -> np.ndarray:
    """MDH errors of the IPSO paper's size on the parameters an identification can see.

    Uniform in +-``mm`` for lengths and +-``rad`` for angles, on Hayati's
    parameter set (``beta_i`` only where axes i and i+1 are parallel, no
    ``d_i`` there, no ``beta6``), so the truth is representable exactly.

    Returns
    -------
    ndarray, shape (6, 5)
    """
    candidates, _ = parameters.structural_candidates(nominal_mdh, "base", True)
    mask = np.isin(np.array(parameters.MDH_NAMES), candidates).reshape(6, 5)
    scale = np.array([mm if u == "mm" else rad for u in kinematics.UNITS])
    return rng.uniform(-1, 1, (6, 5)) * scale * mask


def sample_joints(limits: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` joint vectors uniform in [-pi, pi] within ``limits`` (6, 2), rad."""
    lo = np.maximum(limits[:, 0], -np.pi)
    hi = np.minimum(limits[:, 1], np.pi)
    return rng.uniform(lo, hi, (n, 6))


def tracker_readings(
    points: np.ndarray, n_readings: int, sigma_mm: float, rng: np.random.Generator
) -> np.ndarray:
    """Readings of a tracker at the tracker-frame origin: anisotropic noise.

    Along the beam the noise is ``sigma_mm``; across it, ``sigma_mm`` plus
    the transverse growth of :data:`calibrator.model.noise.TRACKER_NOISE` (6 um/m of range over 2:
    Leica's transverse MPE grows with range, the along-beam one hardly does).

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        True points, tracker frame (mm).
    n_readings : int
    sigma_mm : float
        Standard deviation along the beam of one reading (mm).

    Returns
    -------
    ndarray, shape (N, n_readings, 3)
    """
    rng_m = np.linalg.norm(points, axis=1, keepdims=True)
    beam = points / np.maximum(rng_m, 1e-9)
    # The tracker noise model's transverse growth with range, as a standard deviation (mm per mm)
    growth = TRACKER_NOISE.transverse_mpe_um[1] / TRACKER_NOISE.mpe_over_sigma / 1000.0
    transverse = sigma_mm + growth * rng_m / 1000.0 if sigma_mm else 0.0 * rng_m
    noise = rng.standard_normal((len(points), n_readings, 3))
    along = np.einsum("nrj,nj->nr", noise, beam)[..., None] * beam[:, None]
    across = noise - along
    return points[:, None] + along * sigma_mm + across * transverse[:, None]


#: Seconds between the timestamps of a dated simulated session's poses.
POSE_SECONDS = 10.0


def _timestamps(start: datetime, poses: int) -> list[str]:
    """ISO 8601 UTC times of ``poses`` poses from ``start``, :data:`POSE_SECONDS` apart."""
    first = start.astimezone(UTC) if start.tzinfo is not None else start.replace(tzinfo=UTC)
    return [
        (first + timedelta(seconds=POSE_SECONDS * i)).isoformat(timespec="milliseconds")
        for i in range(poses)
    ]


def simulate(
    model: str = ipso_paper.NAME,
    poses: int = 32,
    seed: int = 3,
    frame: str = "base",
    orientation: bool = True,
    noise_mm: float = 0.0,
    orientation_noise_rad: float = 0.0,
    joint_noise_rad: float = 0.0,
    errors: str = "ref003",
    tool_offset_mm: float = 0.0,
    n_readings: int = 10,
    measured_at: datetime | None = None,
) -> tuple[pa.Table, SessionMeta, Truth]:
    """Simulate a measured session.

    Parameters
    ----------
    model : str
        Named model of the nominal arm.
    poses : int
    seed : int
    frame : {'base', 'tracker'}
        ``base``: points are given in the robot base frame; ``tracker``: in
        the frame of a tracker standing about 3 m away, turned arbitrarily.
    orientation : bool
        Record the probe orientation (6-DoF probe).
    noise_mm : float
        RMS 3-D error of a recorded (averaged) point (mm).
    orientation_noise_rad : float
        RMS rotation angle error of a recorded orientation (rad).
    joint_noise_rad : float
        Standard deviation of the encoder error per joint (rad): the joint
        angles read back differ from the true ones by this.
    errors : {'ref003', 'random', 'none'}
        ``ref003``: Table 2 of reference paper 003 (ER10L-C10 only; ``'seed'``
        is its old name); ``random``: errors of the same size, drawn with
        ``seed``.
    tool_offset_mm : float
        If non-zero, the true tool point differs from the session's first
        guess by a random vector of this length and the tool is unknown;
        otherwise the tool is known exactly.
    n_readings : int
        Readings averaged per pose.
    measured_at : datetime, optional
        When the session was measured (aware, or naive UTC): the poses get a
        ``timestamp`` column from this time on, :data:`POSE_SECONDS` apart,
        so a history of dated sessions can be built at once. None: no
        timestamps (the history then takes the file's time).

    Returns
    -------
    table : pyarrow.Table
    meta : calibrator.session.SessionMeta
    truth : Truth
    """
    from calibrator import session  # the session module imports the model layer

    rng = np.random.default_rng(seed)
    robot = robots.get(model)
    errors = "ref003" if errors == "seed" else errors  # its old name
    if errors == "ref003":
        if robot.reference_errors is None:
            raise ValueError(
                f"the ref003 error table (paper 003, Table 2) is for {ipso_paper.NAME}; "
                "use random errors for other models"
            )
        delta = np.array(robot.reference_errors)
    elif errors == "random":
        delta = random_errors(robot.mdh, rng)
    elif errors == "none":
        delta = np.zeros((6, 5))
    else:
        raise ValueError(f"errors must be 'ref003', 'random' or 'none', got {errors!r}")
    true_mdh = robot.mdh + delta

    tool_guess = frames.transform(translation=DEFAULT_TOOL_MM)
    if errors == "ref003" and not tool_offset_mm:
        tool_guess = np.eye(4)  # the IPSO paper measures the flange itself
    true_tool = tool_guess.copy()
    if tool_offset_mm:
        direction = rng.standard_normal(3)
        true_tool[:3, 3] += tool_offset_mm * direction / np.linalg.norm(direction)

    # The tracker stands about 3 m from the robot, turned arbitrarily.
    base2tracker = frames.transform(
        rotations.rotvec_to_matrix(rng.uniform(-np.pi, np.pi, 3) / 2),
        rng.uniform(-1, 1, 3) * 1000 + [3000.0, 0, 0],
    )

    q_true = sample_joints(robot.joint_limits_rad, poses, rng)
    q_read = q_true + rng.normal(0.0, joint_noise_rad, q_true.shape) if joint_noise_rad else q_true
    pose = kinematics.forward(true_mdh, q_true, true_tool, base2tracker)  # tracker frame
    sigma = noise_mm * np.sqrt(n_readings / 3.0)  # per axis, per reading
    readings = tracker_readings(pose[:, :3, 3], n_readings, sigma, rng)
    points, spread = readings.mean(axis=1), readings.std(axis=1, ddof=1)
    turned = pose[:, :3, :3]
    if orientation_noise_rad:
        tilt = rng.normal(0.0, orientation_noise_rad / np.sqrt(3.0), (poses, 3))
        turned = rotations.rotvec_to_matrix(tilt) @ turned

    if frame == "base":
        # The user aligned the tracker to the base: express everything there.
        tracker2base = frames.invert(base2tracker)
        points = points @ tracker2base[:3, :3].T + tracker2base[:3, 3]
        spread = np.abs(spread @ tracker2base[:3, :3].T)
        turned = tracker2base[:3, :3] @ turned
        recorded_base = np.eye(4)
    elif frame == "tracker":
        recorded_base = base2tracker
    else:
        raise ValueError(f"frame must be 'base' or 'tracker', got {frame!r}")

    table = session.to_table(
        robot.convention.to_controller(q_read),  # as the robot reports them
        points,
        rotvecs=rotations.matrix_to_rotvec(turned) if orientation else None,
        spread=spread if noise_mm else None,
        n_readings=np.full(poses, n_readings),
        timestamps=None if measured_at is None else _timestamps(measured_at, poses),
    )
    meta = session.SessionMeta(
        frame=frame,
        nominal_mdh=robot.mdh,
        model=robot.name,
        flange2tool=tool_guess,
        tool_known=not tool_offset_mm,
        extra={
            "simulated": {
                "seed": seed,
                "noise_mm": noise_mm,
                "orientation_noise_rad": orientation_noise_rad,
                "joint_noise_rad": joint_noise_rad,
                "errors": errors,
            }
        },
    )
    return table, meta, Truth(true_mdh, recorded_base, true_tool)
