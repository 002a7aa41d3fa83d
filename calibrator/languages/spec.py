"""What every program writer is given: the plan, home pose, motion caps, dwell and pulse."""

from __future__ import annotations

from dataclasses import dataclass
from decimal import ROUND_CEILING, ROUND_FLOOR, ROUND_HALF_EVEN, Decimal

import numpy as np
from numpy.typing import ArrayLike

from calibrator.errors import CalibrationError
from calibrator.robots import JointConvention

#: Decimals written for angles: 1e-6 deg and 1e-9 rad, far below the 1e-6 rad round trip
#: (a controller storing 32-bit floats keeps about 3e-7 rad at 180 deg).
DEG_DECIMALS = 6
RAD_DECIMALS = 9
#: Length of the optional digital-output pulse at each arrival, s.
PULSE_S = 0.1
#: Slowest leading-joint speed (rad/s) and acceleration (rad/s^2) a program is
#: written with: a 1 rad move then takes over 15 minutes; slower is a typo.
MIN_SPEED_RAD_S = 1e-3
MIN_ACCEL_RAD_S2 = 1e-3
#: Longest dwell at a pose, s (the readings of a pose take seconds).
MAX_DWELL_S = 600.0


@dataclass(frozen=True)
class ProgramSpec:
    """A measurement program, language-free.

    Attributes
    ----------
    plan_rad : numpy.ndarray, shape (N, 6)
        Joint targets in plan order, rad.
    home_rad : numpy.ndarray, shape (6,)
        Safe start and end pose, rad.
    speed_rad_s, accel_rad_s2 : float
        Leading-joint speed and acceleration caps, rad/s and rad/s^2.
    max_joint_speed_rad_s : numpy.ndarray, shape (6,)
        Each axis's rated top speed, rad/s (for languages that set speed as a percentage).
    dwell_s : float
        Wait at each pose, s.
    pulse_output : int or None
        Digital output pulsed for :data:`PULSE_S` at each arrival (None: no pulse).
    name : str
        Program (procedure) name.
    model : str
        The arm model, written in the header.
    via_rad : tuple of N ndarrays, shape (k_i, 6)
        Joint vectors moved through before pose i, rad (:attr:`calibrator.planning.Plan.via_rad`):
        joint moves without dwell or pulse, so the controller follows the path the plan
        checked in the cell. Default: none.
    joint_limits_rad : numpy.ndarray, shape (6, 2), optional
        The arm's joint limits (model angles), rad: written angles are rounded
        toward their inside (:meth:`angles`), so a target at a limit is never
        written past it.
    convention : calibrator.robots.JointConvention, optional
        How the controller's angles relate to the model's (sign, zero offset,
        coupled axes): programs are written in the controller's angles. None:
        the same angles.
    targets : {'joints', 'cartesian'}
        ``cartesian``: each measured pose's move goes to the flange pose the
        nominal model ``mdh`` gives at its joints (:meth:`flange_pose`), a
        target ``calibrator compensate`` corrects; home and vias stay joint
        targets. Default ``joints``.
    mdh : numpy.ndarray, shape (6, 5), optional
        The nominal MDH table (mm, rad) of ``cartesian`` targets.
    """

    plan_rad: np.ndarray
    home_rad: np.ndarray
    speed_rad_s: float
    accel_rad_s2: float
    max_joint_speed_rad_s: np.ndarray
    dwell_s: float = 2.0
    pulse_output: int | None = None
    name: str = "calibrator_measure"
    model: str = ""
    via_rad: tuple = ()
    joint_limits_rad: np.ndarray | None = None
    convention: JointConvention | None = None
    targets: str = "joints"
    mdh: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.targets not in ("joints", "cartesian"):
            raise CalibrationError(f"targets {self.targets!r}: joints or cartesian")
        if self.targets == "cartesian" and (self.mdh is None or np.shape(self.mdh) != (6, 5)):
            raise CalibrationError("cartesian targets need the nominal MDH table, shape (6, 5)")
        plan = np.asarray(self.plan_rad, dtype=float)
        if plan.ndim != 2 or plan.shape[1] != 6 or not len(plan):
            raise CalibrationError(f"a program needs a plan of shape (N, 6), got {plan.shape}")
        via = tuple(np.asarray(v, dtype=float).reshape(-1, 6) for v in self.via_rad)
        if via and len(via) != len(plan):
            raise CalibrationError(f"{len(via)} via lists for {len(plan)} poses")
        object.__setattr__(self, "via_rad", via or tuple(np.zeros((0, 6)) for _ in plan))
        if np.asarray(self.home_rad).shape != (6,):
            raise CalibrationError("the home pose needs 6 joint angles")
        if not self.speed_rad_s >= MIN_SPEED_RAD_S:
            raise CalibrationError(
                f"speed {self.speed_rad_s:g} rad/s is below {MIN_SPEED_RAD_S:g} rad/s "
                "(a 1 rad move would take over 15 minutes)"
            )
        if not self.accel_rad_s2 >= MIN_ACCEL_RAD_S2:
            raise CalibrationError(
                f"acceleration {self.accel_rad_s2:g} rad/s^2 is below {MIN_ACCEL_RAD_S2:g} rad/s^2"
            )
        if not PULSE_S < self.dwell_s <= MAX_DWELL_S:
            raise CalibrationError(
                f"dwell {self.dwell_s:g} s is not in ({PULSE_S}, {MAX_DWELL_S:g}] s "
                "(longer than the pulse, at most 10 minutes)"
            )
        if not self.name.isidentifier() or not self.name.isascii():
            raise CalibrationError(f"program name {self.name!r} is not an identifier")

    def moves(self) -> list[tuple[str, int | None, np.ndarray, np.ndarray]]:
        """Every joint move in order: ``(kind, pose, start_rad, end_rad)``.

        ``kind`` is ``home``, ``via`` (moved through before ``pose``: no dwell,
        no pulse) or ``pose`` (a measured pose: dwell, and pulse if asked).
        """
        out: list[tuple[str, int | None, np.ndarray, np.ndarray]] = []
        here = np.asarray(self.home_rad, dtype=float)
        out.append(("home", None, here, here))
        for pose, q in enumerate(np.asarray(self.plan_rad, dtype=float)):
            for via in self.via_rad[pose]:
                out.append(("via", pose, here, via))
                here = via
            out.append(("pose", pose, here, q))
            here = q
        out.append(("home", None, here, np.asarray(self.home_rad, dtype=float)))
        return out

    def flange_pose(self, q_rad: ArrayLike) -> np.ndarray:
        """The nominal flange pose at the model's joint angles ``q_rad`` (6,), shape (4, 4).

        In the model's base frame, mm: the pose a ``cartesian`` target states.
        """
        from calibrator.model import kinematics

        assert self.mdh is not None, "flange poses need the spec's mdh"
        return kinematics.chain(self.mdh, np.asarray(q_rad, dtype=float).reshape(1, 6))[0]

    def speed_percent(self, step: float = 0.1, language: str = "KRL") -> np.ndarray:
        """Per-axis speed as a percentage of each axis's top speed, shape (6,), rounded down.

        ``step`` is the finest percentage the language states (KRL 0.1, Fanuc 1),
        also its smallest: a speed below it on any axis cannot be written without
        moving faster than asked, and is refused.

        Raises
        ------
        CalibrationError
            The speed is below ``step`` percent of an axis's top speed.
        """
        top = np.asarray(self.max_joint_speed_rad_s, dtype=float)
        pct = 100.0 * self.speed_rad_s / top
        # A hair of tolerance: 0.3 % computed as 0.29999999 is 0.3 %.
        floored = np.floor(pct / step + 1e-9) * step
        if np.any(floored < step):
            slowest = step / 100.0 * float(top.max())
            raise CalibrationError(
                f"speed {self.speed_rad_s:g} rad/s is below {step:g} % of an axis's top speed, "
                f"the slowest {language} can state ({slowest:.4g} rad/s): give at least that"
            )
        return np.minimum(floored, 100.0)

    def angles(self, q_rad: ArrayLike, unit: str) -> list[str]:
        """The six joint angles of ``q_rad`` as program text: the controller's, rounded inward.

        Parameters
        ----------
        q_rad : array_like, shape (6,)
            The model's joint angles, rad.
        unit : {'rad', 'deg'}
            Written with :data:`RAD_DECIMALS` or :data:`DEG_DECIMALS` decimals.

        Returns
        -------
        list of 6 str
            The angles the controller displays and programs use
            (:attr:`convention`), each rounded to nearest except where that would
            cross the joint limit (``q3`` of exactly pi is written 3.141592653,
            not 3.141592654). A joint coupled to earlier ones (Fanuc's J3) is
            bounded with their angles as written.
        """
        convention = self.convention if self.convention is not None else JointConvention()
        ctrl = convention.to_controller(np.asarray(q_rad, dtype=float).reshape(6))
        scale, decimals = (180.0 / np.pi, DEG_DECIMALS) if unit == "deg" else (1.0, RAD_DECIMALS)
        limits = self.joint_limits_rad
        texts: list[str] = []
        written = np.zeros(6)  # controller angles as written, rad
        for j in range(6):
            low = high = None
            if limits is not None:
                # model_j = sign_j * ctrl_j + offset_j + sum(f * ctrl_k): solve for ctrl_j.
                base = convention.offset_rad[j] + sum(
                    f * written[k] for jj, k, f in convention.couplings if jj == j
                )
                ends = sorted((float(lim) - base) / convention.sign[j] for lim in limits[j])
                low, high = ends[0] * scale, ends[1] * scale
            texts.append(inward(ctrl[j] * scale, decimals, low, high))
            written[j] = float(texts[-1]) / scale
        return texts


def trapezoid_duration_s(distance_rad: float, speed_rad_s: float, accel_rad_s2: float) -> float:
    """Duration of a rest-to-rest move of ``distance_rad`` with a trapezoidal speed profile, s.

    Triangular (accelerate, then brake) when the move is too short to reach the speed.
    """
    distance = abs(float(distance_rad))
    if distance == 0.0:
        return 0.0
    if distance >= speed_rad_s**2 / accel_rad_s2:
        return distance / speed_rad_s + speed_rad_s / accel_rad_s2
    return 2.0 * float(np.sqrt(distance / accel_rad_s2))


def move_duration_s(
    start_rad: ArrayLike, end_rad: ArrayLike, speed_rad_s: float, accel_rad_s2: float
) -> float:
    """Duration of a synchronous joint move whose leading joint keeps to the caps, s.

    ``start_rad`` and ``end_rad`` have shape (6,); a time-programmed move this
    long never exceeds either cap.
    """
    lead = float(np.max(np.abs(np.asarray(end_rad, float) - np.asarray(start_rad, float))))
    return trapezoid_duration_s(lead, speed_rad_s, accel_rad_s2)


def inward(value: float, decimals: int, low: float | None, high: float | None) -> str:
    """``value`` with ``decimals`` decimals, rounded to nearest unless that leaves [low, high].

    Exact decimal arithmetic: the text, read back, is never beyond a limit.
    """
    step = Decimal(1).scaleb(-decimals)
    d = Decimal(float(value)).quantize(step, ROUND_HALF_EVEN)
    if high is not None and d > Decimal(float(high)):
        d = Decimal(float(high)).quantize(step, ROUND_FLOOR)
    if low is not None and d < Decimal(float(low)):
        d = Decimal(float(low)).quantize(step, ROUND_CEILING)
    return f"{d:f}"


def number(value: float) -> str:
    """A speed, acceleration or time as the shortest decimal that reads back as ``value``.

    Never rounded to zero, never in exponent notation (not every language reads it).
    """
    return np.format_float_positional(float(value), trim="0")
