"""The quick circle test as a procedure: its options, its run, its document.

The circle is ``verify --path circle``'s (the cube and orientation of
verify's default pose test, facing the tracker), the tool and registration
the calibration's; the robot runs it clockwise then counter-clockwise with
compensated commands (:data:`calibrator.acquire.ports.FOLLOW_PATH`) while
the tracker streams it, and :mod:`calibrator.check.circle` reads the figures
and the verdict. From Python::

    from calibrator import calibration, robots
    from calibrator.check import circle_procedure as circle_test
    from drivers.devices import Devices

    cal = calibration.load("cal.json")
    options = circle_test.Options(cal, Path("cal.json"))
    result = circle_test.run(robots.get(cal.model), options, "circle.json", Devices())
    result.document["verdict"]

Devices whose robot cannot run a timed path (a real arm today) are refused
before anything moves.
"""

from __future__ import annotations

import json
from contextlib import ExitStack
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from calibrator import calibration as calibrations
from calibrator import outputs
from calibrator.acquire import ports
from calibrator.check import circle as circles
from calibrator.errors import CalibrationError
from calibrator.model import frames
from calibrator.verify import pose
from calibrator.verify.path import PathTracker

#: The document's format and version.
FORMAT, VERSION = "calibrator-check-circle", 1


@dataclass(frozen=True)
class Options:
    """What one circle test does.

    Attributes
    ----------
    calibration : calibrator.calibration.Calibration
        Compensates the commands; its tool and base frame are the test's.
    calibration_path : Path
        Where it was read (named and hashed in the document).
    speed_mm_s : float
        Tool speed along the circle.
    tracker_at_mm : tuple of 3 float, optional
        Where a simulated tracker is put (robot base frame, mm); None: where
        the devices say it stands.
    seed : int
        Seed of the simulated cell.
    """

    calibration: Any
    calibration_path: Path
    speed_mm_s: float = circles.SPEED_MM_S
    tracker_at_mm: tuple[float, float, float] | None = None
    seed: int = 0


@dataclass
class Result:
    """The circle test as written: ``document`` (its ``circle`` section and ``verdict``)."""

    document: dict

    @property
    def verdict(self) -> str:
        """``ok`` or ``flagged``."""
        return str(self.document["verdict"])


def run(
    arm: Any,
    options: Options,
    output: str | Path,
    devices: ports.Devices,
    *,
    inputs: list[Path] | None = None,
) -> Result:
    """Run the circle both ways, compute its verdict and write ``output`` (JSON).

    ``inputs``: files the output must not overwrite.

    Raises
    ------
    CalibrationError
        A robot that cannot run a path, a circle out of reach, a broken stream.
    """
    cal = options.calibration
    flange2tool = frames.transform(translation=cal.flange2tool[:3, 3])
    registration = pose.from_calibration(cal, options.calibration_path)
    with ExitStack() as stack:
        opened = devices.open(arm, options.seed, options.tracker_at_mm, stack)
        robot, tracker = opened.robot, opened.tracker
        # Closed whatever happens next, the robot first (as they were opened, reversed).
        stack.callback(tracker.close)
        stack.callback(robot.close)
        if (
            not (ports.FOLLOW_PATH.offered_by(robot) and isinstance(tracker, PathTracker))
            or opened.tracker_at_mm is None
        ):
            raise CalibrationError(
                "--circle runs on the simulated cell only "
                "(--robot sim, --tracker sim or emscon+sim) for now"
            )
        # The circle's plane and orientation are verify's (its cube, facing the tracker),
        # the tool the calibration's: the same circle every day.
        at = tuple(opened.tracker_at_mm)
        vplan = pose.make_plan(arm, flange2tool, 2, None, cal, at, None)
        tracker.connect()
        opened.robot.connect()
        section = circles.run(
            robot,
            tracker,
            arm,
            flange2tool,
            vplan,
            options.speed_mm_s,
            cal,
            registration.tracker2base,
        )
        robot_id = str(getattr(robot, "device_id", "") or type(robot).__name__)
        tracker_id = str(getattr(tracker, "device_id", "") or type(tracker).__name__)
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "test": "circle",
        "model": arm.name,
        # Who and when, as a check records them (the history files the test under them).
        "robot": robot_id,
        "tracker": tracker_id,
        "time": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "calibration": str(options.calibration_path),
        "calibration_sha256": calibrations.digest(options.calibration_path),
        "circle": section,
        "verdict": section["verdict"],
    }
    with outputs.Outputs(inputs=inputs or []) as batch:
        batch.text(Path(output), json.dumps(doc, indent=2, allow_nan=False) + "\n")
    return Result(doc)
