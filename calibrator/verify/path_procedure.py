"""The ISO 9283 path test as a procedure: its options, its run, its document.

The path lies in the pose test's cube (:func:`calibrator.verify.procedure.prepare`
plans it, so the same cube, tool, calibration and tracker position); the
robot runs its joint commands (:data:`calibrator.acquire.ports.FOLLOW_PATH`)
while the tracker streams it (:mod:`calibrator.verify.path`); the document is
verify.json with its ``path`` section and the streams beside it as .parquet,
both or neither. From Python::

    from calibrator import robots
    from calibrator.verify import path_procedure as path_test
    from drivers.devices import Devices

    options = path_test.Options("circle", path_test.Speed(50.0, percent=True), cycles=3)
    result = path_test.run(robots.get("ur10e"), options, "circle.json", Devices())
    result.document["path"]["AT_P_mm"]

Devices whose robot cannot run a timed path are refused before anything
moves. A UR (``ur://HOST``) runs it and streams its actual joints, and its
stream is aligned with the tracker's (``alignment``: ``robot stream``). An
arm running its own path program (``--robot external``: the program
``calibrator program --path`` writes) is measured tracker-only
(:mod:`calibrator.verify.path_external`).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from calibrator import outputs
from calibrator.acquire import ports
from calibrator.acquire.external.arm import ProgramArm
from calibrator.errors import CalibrationError
from calibrator.model import frames, joint_terms, kinematics
from calibrator.verify import path as verify_path
from calibrator.verify import path_external, pose
from calibrator.verify import procedure as pose_test

#: Default path speed, mm/s (a tenth of a small arm's rated tool speed: ISO's 10 % case).
DEFAULT_SPEED_MM_S = 100.0


@dataclass(frozen=True)
class Speed:
    """The path speed: mm/s, or a percentage of the path's rated speed."""

    value: float
    percent: bool = False

    def __str__(self) -> str:
        return f"{self.value:g} %" if self.percent else f"{self.value:g} mm/s"


@dataclass(frozen=True)
class Options:
    """What one path test does.

    Attributes
    ----------
    shape : {'line', 'circle', 'rectangle'}
        The path (:func:`calibrator.verify.path.test_path`).
    speed : Speed
        Tool speed along it.
    cycles : int
        Runs of the path (at least 2).
    test : calibrator.verify.procedure.Options
        The pose test's options whose cube, tool, calibration, registration,
        tracker position and seed the path takes (its ``cycles`` are this
        test's).
    say : callable, optional
        With an arm running its own program: told when to start it.
    """

    shape: str
    speed: Speed = field(default_factory=lambda: Speed(DEFAULT_SPEED_MM_S))
    cycles: int = 10
    test: pose_test.Options = field(default_factory=pose_test.Options)
    say: Callable[[str], None] | None = None


@dataclass
class Result:
    """A path test's outcome, as written.

    Attributes
    ----------
    document : dict
        verify.json (its ``path`` section holds the figures).
    streams : pandas.DataFrame
        The aligned streams (:data:`calibrator.verify.path.STREAM_COLUMNS`), as
        written beside it.
    data : Path
        Where the streams went.
    speed_mm_s, rated_mm_s : float
        The commanded path speed and the path's rated speed, mm/s.
    compensated : bool
        The commands were compensated by the calibration.
    registration : calibrator.verify.pose.Registration
    """

    document: dict
    streams: pd.DataFrame
    data: Path
    speed_mm_s: float
    rated_mm_s: float
    compensated: bool
    registration: pose.Registration


def model_points(
    arm: Any, flange2tool: np.ndarray, calibration: Any = None
) -> Callable[[np.ndarray], np.ndarray]:
    """The model's tool positions at joints read back: the robot stream's tool path.

    Parameters
    ----------
    arm : calibrator.robots.RobotDescription
    flange2tool : ndarray, shape (4, 4)
        The tool, mm.
    calibration : calibrator.calibration.Calibration, optional
        Its model (and joint terms) instead of the nominal one.

    Returns
    -------
    callable
        Joints (R, 6), rad -> tool positions (R, 3), base frame, mm.
    """
    if calibration is None:
        return lambda q: kinematics.tool_poses(arm.mdh, q, flange2tool)[:, :3, 3]
    terms = calibration.joint_terms
    torque = None
    if terms.used:
        from calibrator.robots import masses

        torque = joint_terms.torque_function(
            terms, calibration.nominal_mdh, masses.for_terms(terms)
        )

    def points(q: np.ndarray) -> np.ndarray:
        if terms.used:  # the angles the joints really turn, from those read back
            q = joint_terms.effective(q, terms.vector(), None if torque is None else torque(q))
        return kinematics.tool_poses(calibration.mdh, q, flange2tool)[:, :3, 3]

    return points


def run(
    arm: Any,
    options: Options,
    output: str | Path,
    devices: ports.Devices,
    *,
    inputs: list[Path] | None = None,
    confirm: Callable[[str], None] | None = None,
) -> Result:
    """Plan, run and write the path test: ``output`` (JSON) and its .parquet beside it.

    ``inputs``: files the outputs must not overwrite. ``confirm(robot_id)`` is
    asked before a real arm (:data:`calibrator.acquire.ports.MOVES_HARDWARE`)
    moves, and raises to refuse; None moves it without asking.

    Raises
    ------
    CalibrationError
        A path out of reach, a robot that cannot run a path, a broken stream,
        a non-finite figure (then nothing is written).
    """
    output = Path(output)
    # The pose test's plan: the cube and the first test pose (orientation, start).
    prepared = pose_test.prepare(
        arm, replace(options.test, cycles=options.cycles), output, devices, inputs=inputs
    )
    vplan, test = prepared.vplan, prepared.test
    flange2tool, calibration = frames.transform(translation=test.tool_mm), test.calibration
    rotation = vplan.desired[0][:3, :3]
    plan_args = (arm, flange2tool, options.shape, vplan.cube, rotation, vplan.q_test[0])
    # The rated speed from the nominal plan: the compensated one differs by microradians.
    rated = verify_path.rated_speed_mm_s(arm, verify_path.plan_path(*plan_args, DEFAULT_SPEED_MM_S))
    speed = options.speed
    speed_mm_s = speed.value / 100.0 * rated if speed.percent else speed.value
    path = verify_path.plan_path(*plan_args, speed_mm_s, calibration)
    with ExitStack() as stack:
        opened = devices.open(arm, test.seed, test.tracker_at_mm, stack)
        robot, tracker = opened.robot, opened.tracker
        # Closed whatever happens next, the robot first (as they were opened, reversed).
        stack.callback(tracker.close)
        stack.callback(robot.close)
        registration = prepared.registration
        if registration is None and opened.surveyed_base2tracker is not None:
            registration = pose.surveyed(opened.surveyed_base2tracker, "simulated cell survey")
        # An arm running its own program (--robot external): tracker-only, from the program.
        external = isinstance(robot, ProgramArm)
        if not (
            (external or ports.FOLLOW_PATH.offered_by(robot))
            and isinstance(tracker, verify_path.PathTracker)
        ):
            raise CalibrationError(
                "--path needs a robot that runs a timed path (sim, ur://HOST) or runs "
                "`calibrator program --path` (--robot external), and a tracker that streams"
            )
        if registration is None:
            raise CalibrationError(
                "--path needs a registration: --calibration, --register or --base-frame"
            )
        if confirm is not None and ports.MOVES_HARDWARE in getattr(robot, "capabilities", ()):
            confirm(str(getattr(robot, "device_id", "") or type(robot).__name__))
        tracker.connect()
        opened.robot.connect()
        if external:
            section, table = path_external.run(
                tracker, path, options.cycles, registration.tracker2base, say=options.say
            )
        else:
            section, table = verify_path.run(
                robot,
                tracker,
                path,
                options.cycles,
                registration.tracker2base,
                tool_points=model_points(arm, flange2tool, calibration),
            )
        robot_id = str(getattr(robot, "device_id", "") or type(robot).__name__)
        tracker_id = str(tracker.device_id or type(tracker).__name__)
    section["rated_speed_mm_s"] = rated
    section["speed_pct"] = 100.0 * speed_mm_s / rated
    doc = {
        "format": pose.FORMAT,
        "version": pose.VERSION,
        "test": "path",
        "model": arm.name,
        # Who and when, as a pose test records them (the history files the test under them).
        "robot": robot_id,
        "tracker": tracker_id,
        "time": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cube": vplan.cube.to_json(),
        "registration": registration.to_json(),
        "path": section,
    }
    figures = [section[k] for k in ("AT_P_mm", "RT_P_mm", "AV_pct", "RV_pct", "FV_mm_s")]
    if not np.all(np.isfinite(figures)):
        raise CalibrationError("the path test gave a non-finite figure: no document from it")
    data = pose.data_path(output)
    doc["data"] = data.name
    with outputs.Outputs(inputs=inputs or []) as batch:  # both files or neither
        batch.text(output, json.dumps(doc, indent=2, allow_nan=False) + "\n")
        batch.file(data, lambda tmp: table.to_parquet(tmp, index=False))
    return Result(doc, table, data, speed_mm_s, rated, path.compensated, registration)
