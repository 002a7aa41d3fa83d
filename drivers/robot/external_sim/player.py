"""Play a plan as a controller runs the exported program, on a hidden true arm.

The program (see :mod:`calibrator.languages.writing`) goes to a safe start pose, makes
one joint move per plan pose with a dwell at each (after the pose's via moves,
passed through without dwell), and ends at the safe pose.
:class:`Player` reproduces that in real time (or, with
:attr:`PlayerOptions.time_scale`, that many times faster) and hands the true
reflector position (tracker frame, mm) to a callback every tick, e.g. a
tracker simulator's ``SIM,TARGET``.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from calibrator.model import kinematics
from drivers.robot.external_sim.motion import JointMove, ringing

#: A step this close to its end (controller time, s) is at its end.
_END_S = 1e-6


@dataclass(frozen=True)
class Hold:
    """The arm at ``q_rad`` (shape (6,), rad) for ``seconds``; ``ring``: it vibrates on arrival."""

    q_rad: np.ndarray
    seconds: float
    ring: bool


@dataclass(frozen=True)
class PlayerOptions:
    """How the simulated controller runs the program.

    Attributes
    ----------
    speed_rad_s, accel_rad_s2 : float
        Leading-joint speed and acceleration of every move (controller time).
    dwell_s : float
        Wait at each pose, s (controller time).
    tick_s : float
        Period of the target updates, s of the wall clock (however fast the
        program runs, the target is updated this often).
    skip : tuple of int
        Plan poses the program leaves out.
    pauses : tuple of (int, float, float)
        ``(pose, fraction, seconds)``: the move to ``pose`` stops ``fraction``
        of the way for ``seconds`` (an operator's pause).
    vibration_mm : float
        Amplitude of the damped ringing after each arrival, mm.
    start_delay_s : float
        Wait before the first move, s (controller time).
    time_scale : float
        Controller seconds per wall-clock second: 4 plays the whole program
        (moves, dwells, pauses, ringing) four times faster than real time, as
        the fake UR controller's ``--time-scale`` does. A tracker simulator at
        the same scale stamps its readings as fast, so the watching run sees
        the program as at real time; one at real time sees dwells
        ``time_scale`` times shorter (see docs/external-robots.md).
    """

    speed_rad_s: float = 1.0
    accel_rad_s2: float = 2.0
    dwell_s: float = 1.5
    tick_s: float = 0.02
    skip: tuple = ()
    pauses: tuple = ()
    vibration_mm: float = 0.0
    start_delay_s: float = 0.0
    time_scale: float = 1.0

    def __post_init__(self) -> None:
        for name in ("speed_rad_s", "accel_rad_s2", "tick_s", "time_scale"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")
        for name in ("dwell_s", "vibration_mm", "start_delay_s"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")


class Player:
    """A true arm running the plan's program.

    Parameters
    ----------
    plan_rad : array_like, shape (N, 6)
    true_mdh : array_like, shape (6, 5)
        The arm as it really is (mm, rad).
    flange2tool, base2tracker : array_like, shape (4, 4)
        True tool and base placement, mm.
    options : PlayerOptions
    safe_rad : array_like, shape (6,), optional
        Start and end pose; default the plan's mean joints (inside its limits).
    via_rad : sequence of N arrays of shape (k_i, 6), optional
        Joints moved through before pose i (no dwell), rad: the plan's via rows.
    """

    def __init__(
        self,
        plan_rad: ArrayLike,
        true_mdh: ArrayLike,
        flange2tool: ArrayLike,
        base2tracker: ArrayLike,
        options: PlayerOptions,
        safe_rad: ArrayLike | None = None,
        via_rad: Sequence[ArrayLike] = (),
    ) -> None:
        self.plan = np.asarray(plan_rad, dtype=float)
        self.via = [np.asarray(v, dtype=float).reshape(-1, 6) for v in via_rad] or [
            np.zeros((0, 6)) for _ in self.plan
        ]
        if len(self.via) != len(self.plan):
            raise ValueError(f"{len(self.via)} via lists for {len(self.plan)} poses")
        self.true_mdh = np.asarray(true_mdh, dtype=float)
        self.flange2tool = np.asarray(flange2tool, dtype=float)
        self.base2tracker = np.asarray(base2tracker, dtype=float)
        self.options = options
        bad = [p for p in options.skip if not 0 <= p < len(self.plan)]
        bad += [p for p, _, _ in options.pauses if not 0 <= p < len(self.plan)]
        if bad:
            raise ValueError(f"pose(s) {bad} not in the plan (0..{len(self.plan) - 1})")
        self.safe = self.plan.mean(axis=0) if safe_rad is None else np.asarray(safe_rad, float)

    @classmethod
    def for_model(
        cls,
        plan_rad: ArrayLike,
        model: str,
        seed: int,
        options: PlayerOptions,
        via_rad: Sequence[ArrayLike] = (),
        world: Any = None,
        tool_mm: ArrayLike | None = None,
    ) -> Player:
        """The hidden cell of ``measure``'s simulation for ``model`` and ``seed``.

        ``world`` (a :class:`calibrator.world.World`) changes it as its file says;
        ``tool_mm`` (shape (3,), mm) puts the reflector there on the flange
        instead of where the hidden cell has it (near the default guess).
        """
        from calibrator.model import frames
        from calibrator.simulate import SimWorld

        cell = SimWorld.make(model, seed) if world is None else world.build(model, seed)
        tool = cell.flange2tool
        if tool_mm is not None:
            tool = frames.transform(translation=np.asarray(tool_mm, dtype=float).reshape(3))
        return cls(
            plan_rad,
            cell.true_mdh,
            tool,
            cell.base2tracker,
            options,
            via_rad=via_rad,
        )

    def write_truth(self, path: str | os.PathLike) -> None:
        """The hidden truth as JSON: ``true_mdh``, ``flange2tool``, ``base2tracker``."""
        truth = {
            "true_mdh": self.true_mdh.tolist(),
            "flange2tool": self.flange2tool.tolist(),
            "base2tracker": self.base2tracker.tolist(),
        }
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(truth, fh)

    def tool_points(self, q_rad: ArrayLike) -> np.ndarray:
        """True reflector positions for joints (M, 6), tracker frame, shape (M, 3), mm."""
        q = np.atleast_2d(np.asarray(q_rad, dtype=float))
        return kinematics.forward(self.true_mdh, q, self.flange2tool, self.base2tracker)[:, :3, 3]

    def script(self) -> list[JointMove | Hold]:
        """The program as segments in order: moves and holds."""
        o = self.options
        pauses = {p: (f, s) for p, f, s in o.pauses}
        steps: list[JointMove | Hold] = [Hold(self.safe, o.start_delay_s, False)]
        here = self.safe
        targets = [p for p in range(len(self.plan)) if p not in set(o.skip)]
        for pose in targets:
            # Vias first, passed through (no dwell), as the program's via moves are:
            # the path the plan checked in the cell. A skipped pose keeps its vias.
            for via in self.via[pose]:
                steps.append(JointMove(here, via, o.speed_rad_s, o.accel_rad_s2))
                here = via
            move = JointMove(here, self.plan[pose], o.speed_rad_s, o.accel_rad_s2)
            if pose in pauses:
                fraction, seconds = pauses[pose]
                midway = here + fraction * (self.plan[pose] - here)
                steps.append(JointMove(here, midway, o.speed_rad_s, o.accel_rad_s2))
                steps.append(Hold(midway, seconds, True))
                move = JointMove(midway, self.plan[pose], o.speed_rad_s, o.accel_rad_s2)
            steps.append(move)
            steps.append(Hold(self.plan[pose], o.dwell_s, True))
            here = self.plan[pose]
        steps.append(JointMove(here, self.safe, o.speed_rad_s, o.accel_rad_s2))
        steps.append(Hold(self.safe, o.dwell_s, False))
        return steps

    def play(
        self,
        send: Callable[[np.ndarray], None],
        *,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        rng: np.random.Generator | None = None,
    ) -> None:
        """Run the program, calling ``send(point_mm)`` every tick (tracker frame).

        ``clock`` and ``sleep`` are the wall clock (s); the program runs
        ``options.time_scale`` controller seconds per wall second.
        """
        rng = np.random.default_rng(0) if rng is None else rng
        o = self.options
        scale = o.time_scale
        for step in self.script():
            position: Callable[[float], np.ndarray]
            if isinstance(step, JointMove):
                duration, position, ring = step.duration, step.at, 0.0
            else:
                duration, ring = step.seconds, (o.vibration_mm if step.ring else 0.0)
                position = _standing(step.q_rad)
            direction = rng.standard_normal(3)
            direction /= np.linalg.norm(direction)
            start = clock()
            while True:
                t = (clock() - start) * scale  # controller time into the step, s
                # Within a microsecond of its end the step is over: a clock stepped by the
                # sleeps asked for can round just short of the end again and again.
                done = t >= duration - _END_S
                if done:
                    t = duration
                point = self.tool_points(position(t))[0]
                if ring:
                    point = point + ringing(t, ring, direction)
                send(point)
                if done:
                    break
                sleep(min(o.tick_s, (duration - t) / scale))


def _standing(q_rad: np.ndarray) -> Callable[[float], np.ndarray]:
    """Joints of an arm that stands still at ``q_rad``, as a function of time."""
    return lambda t: q_rad
