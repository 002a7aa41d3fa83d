"""World files: the simulated cell's true arm, written down, so drift can be tried without hardware.

Every simulator (the simulated robot, both tracker simulators, the external
robot's player) moves one hidden true arm, :class:`calibrator.simulate.SimWorld`,
drawn from a seed. A world file changes that arm the way time changes a real
one (wear, a crash, a re-mastered joint, a moved base, a re-glued reflector)
so that ``measure``, ``check`` and ``verify`` can be run against it
(``--world FILE``; the format is in docs/check.md)::

    world: 1                       # format version
    model: ur10e                   # optional: must be the run's --model
    seed: 3                        # the arm drawn as the simulation draws it [the run's --seed]
    arm:
      errors: drawn                # drawn: the errors drawn from the seed; none: exactly nominal
      deltas: {a2: 0.05, alpha3: 0.0001}   # added to its MDH table (mm, rad)
    joint_zero_shifts_rad: [0, 0.0004, 0, 0, 0, 0]   # true angle = read angle + shift
    base: {translation_mm: [0.1, 0, 0], rotvec_rad: [0, 0, 0]}  # the base moved (its frame)
    reflector_shift_mm: [0, 0, 0]  # the reflector moved on the flange (flange frame)
    noise: true                    # false: the trackers read exactly
    repeatability: false           # true: the arm lands off its targets as a typical arm does
    tracker: {air: [20.0, 1013.25, 50.0], on_minutes: 180}   # its air (degC, hPa, %RH) and
                                   # time since power-on (warmed up after 120 min)

Units: mm and rad. Nothing here touches hardware; the drivers receive the
:class:`~calibrator.simulate.SimWorld` it builds.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.model import frames, kinematics, parameters, rotations
from calibrator.simulate import SimWorld

FORMAT_VERSION = 1
_KEYS = {
    "world",
    "model",
    "seed",
    "arm",
    "joint_zero_shifts_rad",
    "base",
    "reflector_shift_mm",
    "noise",
    "repeatability",
    "tracker",
}
#: Old spellings of ``arm.errors`` values, still read: ``seed`` said where the
#: hidden errors come from in a word that now means only the random seed.
ERRORS_ALIASES = {"seed": "drawn"}
#: Largest change a world file may make (a world, not a different arm): mm, rad.
MAX_CHANGE = {"mm": 50.0, "rad": 0.2}


class WorldError(CalibrationError):
    """A world file is unreadable or does not follow the format."""


@dataclass(frozen=True)
class World:
    """A parsed world file.

    Attributes
    ----------
    model : str or None
        The named arm it is for (None: any).
    seed : int or None
        Seed of the hidden arm (None: the run's seed).
    errors : {'drawn', 'none'}
        Start from the hidden MDH errors drawn from the seed, or from the
        nominal table. A file's ``seed`` is read as ``drawn`` (its old spelling).
    deltas : dict
        MDH deltas added to the true arm ``{name: value}`` (mm, rad).
    joint_zero_shifts_rad : ndarray, shape (6,)
        Added to the true ``theta_i``: the angle the joint really turns to is
        the read angle plus the shift.
    base_translation_mm, base_rotvec_rad : ndarray, shape (3,)
        The base's displacement, in the base frame.
    reflector_shift_mm : ndarray, shape (3,)
        The reflector's displacement on the flange, flange frame.
    noise : bool
        The trackers add their noise.
    repeatability : bool
        The arm has a typical arm's joint positioning error and backlash
        (``drivers.robot.sim.device.JointRepeatability.typical``).
    air : tuple of 3 float, optional
        The air the tracker's station measures: degC, hPa, %RH.
    tracker_on_s : float, optional
        The tracker's time since power-on when the run starts, s.
    """

    model: str | None = None
    seed: int | None = None
    errors: str = "drawn"
    deltas: dict = field(default_factory=dict)
    joint_zero_shifts_rad: np.ndarray = field(default_factory=lambda: np.zeros(6))
    base_translation_mm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    base_rotvec_rad: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reflector_shift_mm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    noise: bool = True
    repeatability: bool = False
    air: tuple | None = None
    tracker_on_s: float | None = None

    def build(self, model_name: str, seed: int, repeatability: Any = None) -> SimWorld:
        """The simulated world of this file for the run's model and seed.

        Parameters
        ----------
        model_name : str
            The run's ``--model``.
        seed : int
            The run's ``--seed``: the arm's seed when the file gives none.
        repeatability : drivers.robot.sim.device.JointRepeatability, optional

        Raises
        ------
        WorldError
            The file is for another model.
        """
        if self.model is not None and self.model != model_name.strip().lower():
            raise WorldError(f"the world file is for a {self.model}, not --model {model_name}")
        world = SimWorld.make(model_name, seed if self.seed is None else self.seed, repeatability)
        mdh = world.true_mdh.copy() if self.errors == "drawn" else world.model.mdh.copy()  # type: ignore[attr-defined]
        for name, value in self.deltas.items():
            i = parameters.MDH_NAMES.index(name)
            mdh[i // 5, i % 5] += value
        mdh[:, kinematics.THETA] += self.joint_zero_shifts_rad
        moved = frames.transform(
            rotations.rotvec_to_matrix(self.base_rotvec_rad), self.base_translation_mm
        )
        tool = world.flange2tool.copy()
        tool[:3, 3] += self.reflector_shift_mm
        return replace(
            world,
            true_mdh=mdh,
            base2tracker=world.base2tracker @ moved,
            flange2tool=tool,
            noise_seed=seed,
            air=self.air,
            tracker_on_s=self.tracker_on_s,
        )


def read_world(path: str | os.PathLike[str]) -> World:
    """Read a world file (YAML); one :class:`WorldError` line naming what is wrong."""
    from calibrator.inputs import yamlfile
    from calibrator.inputs.errors import StrictError

    path = Path(path)
    try:
        # The one YAML reader: size, depth and alias limits, duplicate keys refused.
        doc = yamlfile.read(path, "a world file")
    except StrictError as exc:
        raise WorldError(str(exc)) from None
    if isinstance(doc, dict) and "world" not in doc:
        # The format line says what the file is: a YAML mapping without it (a
        # cell file, a robot description) given as --world is not taken as one.
        raise WorldError(f"{path}: no 'world: {FORMAT_VERSION}' line: not a world file")
    try:
        return parse_world(doc)
    except WorldError as exc:
        raise WorldError(f"{path}: {exc}") from None


def parse_world(doc: object) -> World:
    """A :class:`World` from a parsed YAML document.

    Raises
    ------
    WorldError
        An unknown key, a wrong type, a non-finite or implausibly large value.
    """
    if not isinstance(doc, dict):
        raise WorldError("a world file is a mapping (world: 1, arm: ..., base: ...)")
    unknown = sorted(set(map(str, doc)) - _KEYS)
    if unknown:
        raise WorldError(f"unknown key(s) {', '.join(unknown)}; known: {', '.join(sorted(_KEYS))}")
    if doc.get("world", FORMAT_VERSION) != FORMAT_VERSION:
        raise WorldError(f"world: {doc['world']!r} is not a format this version reads (1)")
    model = doc.get("model")
    if model is not None and not isinstance(model, str):
        raise WorldError(f"model: expected a model name, got {model!r}")
    seed = doc.get("seed")
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, int) or seed < 0):
        raise WorldError(f"seed: expected a non-negative integer, got {seed!r}")
    arm = doc.get("arm") or {}
    if not isinstance(arm, dict) or set(arm) - {"errors", "deltas"}:
        raise WorldError("arm: expected a mapping with errors (drawn|none) and deltas")
    errors = arm.get("errors", "drawn")
    errors = ERRORS_ALIASES.get(errors, errors) if isinstance(errors, str) else errors
    if errors not in ("drawn", "none"):
        raise WorldError(f"arm.errors: expected drawn or none, got {errors!r}")
    deltas = arm.get("deltas") or {}
    if not isinstance(deltas, dict):
        raise WorldError("arm.deltas: expected a mapping of MDH names to deltas (mm, rad)")
    parsed = {}
    for name, value in deltas.items():
        if name not in parameters.MDH_NAMES:
            raise WorldError(f"arm.deltas: {name!r} is not an MDH parameter (a1 .. beta6)")
        parsed[name] = _number(value, f"arm.deltas.{name}", parameters.unit(name))
    base = doc.get("base") or {}
    if not isinstance(base, dict) or set(base) - {"translation_mm", "rotvec_rad"}:
        raise WorldError("base: expected a mapping with translation_mm and rotvec_rad")
    noise, repeatability = doc.get("noise", True), doc.get("repeatability", False)
    for key, value in (("noise", noise), ("repeatability", repeatability)):
        if not isinstance(value, bool):
            raise WorldError(f"{key}: expected true or false, got {value!r}")
    air, on_s = _tracker(doc.get("tracker"))
    return World(
        model=None if model is None else model.strip().lower(),
        seed=seed,
        errors=errors,
        deltas=parsed,
        joint_zero_shifts_rad=_vector(
            doc.get("joint_zero_shifts_rad"), 6, "joint_zero_shifts_rad", "rad"
        ),
        base_translation_mm=_vector(base.get("translation_mm"), 3, "base.translation_mm", "mm"),
        base_rotvec_rad=_vector(base.get("rotvec_rad"), 3, "base.rotvec_rad", "rad"),
        reflector_shift_mm=_vector(doc.get("reflector_shift_mm"), 3, "reflector_shift_mm", "mm"),
        noise=noise,
        repeatability=repeatability,
        air=air,
        tracker_on_s=on_s,
    )


#: The air a tracker measures in (its meteo limits): degC, hPa, %RH.
AIR_LIMITS = ((-10.0, 50.0), (500.0, 1200.0), (0.0, 100.0))


def _tracker(doc: object) -> tuple[tuple | None, float | None]:
    """``tracker: {air: [T, P, H], on_minutes: M}``: the air, and the time on in s."""
    if doc is None:
        return None, None
    if not isinstance(doc, dict) or set(doc) - {"air", "on_minutes"}:
        raise WorldError("tracker: expected a mapping with air ([T, P, H]) and on_minutes")
    air = None
    if doc.get("air") is not None:
        values = doc["air"]
        if not isinstance(values, list) or len(values) != 3:
            raise WorldError(f"tracker.air: expected [degC, hPa, %RH], got {values!r}")
        air = tuple(_plain(v, f"tracker.air[{i}]") for i, v in enumerate(values))
        for v, (lo, hi), name in zip(air, AIR_LIMITS, ("degC", "hPa", "%RH"), strict=True):
            if not lo <= v <= hi:
                raise WorldError(f"tracker.air: {v} {name} outside {lo:g}..{hi:g}")
    on_s = None
    if doc.get("on_minutes") is not None:
        minutes = _plain(doc["on_minutes"], "tracker.on_minutes")
        if minutes < 0:
            raise WorldError(f"tracker.on_minutes: expected minutes >= 0, got {minutes}")
        on_s = 60.0 * minutes
    return air, on_s


def _plain(value: object, what: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise WorldError(f"{what}: expected a finite number, got {value!r}")
    return float(value)


def _number(value: object, what: str, unit: str) -> float:
    # A quoted '4e-4' is text, refused as every non-number is (the strict
    # YAML reader already reads an unquoted 4e-4 as the number).
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise WorldError(f"{what}: expected a finite number ({unit}), got {value!r}")
    if abs(value) > MAX_CHANGE[unit]:
        raise WorldError(f"{what}: {value} {unit} is beyond {MAX_CHANGE[unit]:g} {unit}")
    return float(value)


def _vector(value: object, n: int, what: str, unit: str) -> np.ndarray:
    if value is None:
        return np.zeros(n)
    if not isinstance(value, list) or len(value) != n:
        raise WorldError(f"{what}: expected a list of {n} numbers ({unit}), got {value!r}")
    return np.array([_number(v, f"{what}[{i}]", unit) for i, v in enumerate(value)])
