"""The ISO 9283 pose test run: its plan, the registration of the tracker, the figures.

A thin layer over the measure run (:class:`calibrator.acquire.run.MeasureRun`):
the plan is ``cycles`` times P5, P4, P3, P2, P1 (:func:`make_plan`), measured
with the same plan checks, journal, resume, retries and stops as ``measure``
(:func:`run_options`); before the first pending pose the arm is led in from
the pose that precedes it in the cycle (``RunOptions.lead_in``), so that every
test pose is approached from the same direction, also after a resume. The
finished records become the figures (:func:`evaluate`) in the robot base
frame, through one of three registrations of the tracker frame
(:class:`Registration`), and both files are written at once (:func:`write`):

- ``calibration``: the base frame identified by a calibration
  (``base2tracker`` of calibration.json);
- ``surveyed``: a base frame measured apart from the arm's kinematics, e.g.
  on the fiducials of the robot's base (``--base-frame``; the simulated cell
  gives its own, surveyed with a small seeded error);
- ``fit``: the rigid transform that best maps the barycentres of the attained
  positions onto the commanded positions (least squares, Kabsch). It absorbs
  any offset and turn common to the five poses, so AP is then a lower bound
  of the accuracy in the true base frame; RP does not depend on it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from calibrator import compensate, outputs
from calibrator.acquire.run import RunOptions
from calibrator.calibration import Calibration
from calibrator.errors import CalibrationError
from calibrator.model import frames, rotations
from calibrator.planning import Plan
from calibrator.robots import JointConvention
from calibrator.verify import iso9283

#: Columns of verify.parquet, in order (base frame, mm).
COLUMNS = ("test_pose", "cycle", "x_mm", "y_mm", "z_mm", "cmd_x_mm", "cmd_y_mm", "cmd_z_mm")
FORMAT = "calibrator.verify"
VERSION = 1


@dataclass(frozen=True)
class VerifyPlan:
    """What a verify run commands.

    Attributes
    ----------
    cube : calibrator.verify.iso9283.Cube
    cube_given : bool
        From ``--cube`` rather than :func:`calibrator.verify.iso9283.largest_cube`.
    desired : ndarray, shape (5, 4, 4)
        Test poses P1..P5, tool in the robot base frame, mm.
    q_test : ndarray, shape (5, 6)
        Joint commands of P1..P5, rad (nominal IK, or compensated).
    compensated : bool
    plan : ndarray, shape (5 * cycles, 6)
    test_pose, cycle : ndarray of int, shape (5 * cycles,)
    convention : calibrator.robots.JointConvention
        The arm's: the document states joint commands as its controller does.
    model_base2controller_base : ndarray, shape (4, 4)
        The controller's base frame in the model's: the document states the
        cube and the commanded poses in the controller's.
    """

    cube: iso9283.Cube
    cube_given: bool
    desired: np.ndarray
    q_test: np.ndarray
    compensated: bool
    plan: np.ndarray
    test_pose: np.ndarray
    cycle: np.ndarray
    convention: JointConvention = field(default_factory=JointConvention)
    model_base2controller_base: np.ndarray = field(default_factory=lambda: np.eye(4))

    def shown(self, pose: np.ndarray) -> np.ndarray:
        """A model base frame pose (..., 4, 4) in the controller's base frame, mm."""
        return frames.invert(self.model_base2controller_base) @ pose

    @property
    def cycles(self) -> int:
        return int(self.cycle[-1])


def make_plan(
    model: Any,
    flange2tool: npt.ArrayLike,
    cycles: int,
    cube: iso9283.Cube | None = None,
    calibration: Calibration | None = None,
    tracker_at_mm: npt.ArrayLike | None = None,
    cell: Any = None,
) -> VerifyPlan:
    """The test poses and the run's joint plan.

    Parameters
    ----------
    model : calibrator.robots.RobotDescription
        The controller's nominal model.
    flange2tool : array_like, shape (4, 4)
        Nominal TCP on the flange (mm): the cube and the test poses use it,
        so the same poses are tested with and without a calibration.
    cycles : int
        At least 2 (a repeatability needs a spread).
    cube : calibrator.verify.iso9283.Cube, optional
        Given cube, its centre in the controller's base frame (KUKA
        ``$ROBROOT``, FANUC's World: what the pendant shows; its edges along
        the model's base axes); default the largest cube of the working space.
    calibration : calibrator.calibration.Calibration, optional
        With it the commands are compensated (:func:`calibrator.compensate.compensate`:
        the calibrated arm's joints reaching the desired poses); without it
        they are the nominal model's IK, what an uncalibrated controller does.

    Raises
    ------
    CalibrationError
        A cube out of reach, or a test pose the calibrated arm cannot reach.
    """
    if cycles < 2:
        raise CalibrationError(f"--cycles must be at least 2, got {cycles}")
    limits = model.joint_limits_rad
    given = cube is not None
    base = model.model_base2controller_base
    if cube is not None:
        cube = iso9283.Cube(base[:3, :3] @ cube.centre_mm + base[:3, 3], cube.side_mm)
    rotation = iso9283.TOOL_DOWN
    if tracker_at_mm is not None:
        # The reflector faces the tracker from where the cube will be.
        centre = cube.centre_mm if cube is not None else _TEST_REGION * _reach(model.mdh)
        rotation = iso9283.facing(centre, tracker_at_mm)
    allowed = admissible(model, flange2tool, cell, tracker_at_mm)
    if cube is None:
        # A quick floor above the mounting plane; the cell's checks decide the rest.
        cube = iso9283.largest_cube(
            model.mdh, limits, flange2tool, rotation, CUBE_FLOOR_ABOVE_PLANE_MM, allowed
        )
    else:
        iso9283.check_cube(model.mdh, limits, flange2tool, cube, rotation, allowed)
    desired = iso9283.test_poses(cube.centre_mm, cube.side_mm, rotation)
    q = iso9283.commanded_joints(model.mdh, limits, flange2tool, cube, rotation, allowed)
    if calibration is not None:
        result = compensate.compensate(calibration, desired=desired, q_nominal=q, limits=limits)
        bad = np.flatnonzero(~result.solution.ok)
        if bad.size:
            raise CalibrationError(
                f"the calibrated arm cannot reach test pose P{int(bad[0]) + 1} within its "
                "joint limits: choose a smaller --cube"
            )
        q = result.q
    plan, test_pose, cycle = iso9283.cycle_plan(q, cycles)
    return VerifyPlan(
        cube,
        given,
        desired,
        q,
        calibration is not None,
        plan,
        test_pose,
        cycle,
        model.convention,
        base,
    )


def admissible(
    model: Any,
    flange2tool: npt.ArrayLike,
    cell: Any = None,
    tracker_at_mm: npt.ArrayLike | None = None,
) -> iso9283.Admissible:
    """The cell's pose and motion checks as the predicates the cube search takes.

    Parameters
    ----------
    model : calibrator.robots.RobotDescription
    flange2tool : array_like, shape (4, 4)
        Tool on the flange, mm: its origin is the reflector the capsule model carries.
    cell : calibrator.cell.Cell, optional
        Default the bare cell (the model's mounting plane, 20 mm margin).
    tracker_at_mm : array_like, shape (3,), optional
        With it the tracker's checks (line of sight, range, acceptance) apply.

    Raises
    ------
    calibrator.cell.CellError
        The tracker stands where the arm could hit it.
    """
    from calibrator import cell as cells

    tool_mm = np.asarray(flange2tool, float)[:3, 3]
    at = None if tracker_at_mm is None else tuple(np.asarray(tracker_at_mm, float).reshape(3))
    where = (cell if cell is not None else cells.Cell()).with_tracker(at)
    chk = cells.checker(cells.arm_geometry(model.name, model.mdh, tool_mm), where)
    # A tracker the arm could hit is refused as such, not as "no cube fits".
    cells.check_tracker_placement(chk)
    return iso9283.Admissible(
        poses=lambda q: np.asarray(~cells.pose_faults(chk, q).any(axis=1)),
        moves=lambda qa, qb: np.asarray(~cells.motion_faults(chk, qa, qb).any(axis=1)),
    )


#: Where the test region lies, as fractions of the arm's reach (x, y, z), base frame.
_TEST_REGION = np.array([0.45, 0.0, 0.3])


def _reach(mdh: npt.ArrayLike) -> float:
    table = np.asarray(mdh, float)
    return float(np.abs(table[:, 0]).sum() + np.abs(table[:, 3]).sum())


#: Lowest z of a default test cube, base frame, mm: the robot's mounting plane
#: is z = 0 for every named model; the tool pointing down keeps its capsule and
#: the wrist this far clear of it.
CUBE_FLOOR_ABOVE_PLANE_MM = 200.0


def run_options(plan: VerifyPlan, **options: Any) -> RunOptions:
    """The measure run of a verify plan: its rows, led in, any plan length allowed.

    ``options`` are further :class:`~calibrator.acquire.run.RunOptions` fields
    (readings, speed, resume...).
    """
    return RunOptions(plan=Plan(plan.plan), lead_in=True, need_poses=len(plan.plan), **options)


def data_path(output: str | Path) -> Path:
    """Where the attained poses of ``verify.json`` go: ``verify.parquet`` beside it."""
    return Path(output).with_suffix(".parquet")


@dataclass(frozen=True)
class Registration:
    """How tracker-frame readings become robot base frame positions.

    Attributes
    ----------
    method : {'calibration', 'surveyed', 'fit'}
    tracker2base : ndarray, shape (4, 4)
    source : str
        The calibration file, or what the fit used.
    rms_mm : float or None
        Fit only: RMS of the barycentres about the commanded positions after the fit.
    """

    method: str
    tracker2base: np.ndarray
    source: str
    rms_mm: float | None = None

    def to_json(self) -> dict:
        out = {
            "method": self.method,
            "frame": "robot base",
            "source": self.source,
            "tracker2base": np.asarray(self.tracker2base).tolist(),
        }
        if self.method == "calibration":
            out["note"] = "base frame identified by the calibration (its base2tracker)"
        elif self.method == "surveyed":
            out["note"] = "base frame measured apart from the arm's kinematics (surveyed base)"
        else:
            out["note"] = (
                "rigid least-squares fit of the attained barycentres onto the commanded "
                "positions: a common offset and turn is absorbed, so AP is a lower bound"
            )
            out["rms_mm"] = self.rms_mm
        return out


def from_calibration(calibration: Calibration, path: object) -> Registration:
    """The base frame a calibration identified."""
    return Registration("calibration", frames.invert(calibration.base2tracker), str(path))


def surveyed(base2tracker: npt.ArrayLike, source: str) -> Registration:
    """A base frame measured apart from the arm (base2tracker, (4, 4), mm)."""
    t = frames.check_transform(np.asarray(base2tracker, float), "base2tracker")
    return Registration("surveyed", frames.invert(t), source)


def fit(points_tracker_mm: npt.ArrayLike, plan: VerifyPlan) -> Registration:
    """Best-fit registration of the barycentres onto the commanded positions.

    Parameters
    ----------
    points_tracker_mm : array_like, shape (5 * cycles, 3)
        Attained positions of every plan row, tracker frame, mm.
    """
    pts = np.asarray(points_tracker_mm, float)
    bary = np.array([pts[plan.test_pose == k].mean(axis=0) for k in range(1, 6)])
    commanded = plan.desired[:, :3, 3]
    t2b = frames.fit_rigid(bary, commanded)
    moved = bary @ t2b[:3, :3].T + t2b[:3, 3]
    rms = float(np.sqrt(np.mean(np.sum((moved - commanded) ** 2, axis=1))))
    return Registration("fit", t2b, "barycentres of the 5 test poses", rms)


def points(records: dict, plan: VerifyPlan) -> tuple[np.ndarray, np.ndarray | None]:
    """Attained positions (N, 3) mm and rotation vectors (N, 3) rad or None, tracker frame.

    Raises
    ------
    CalibrationError
        A plan row without a measured record.
    """
    n = len(plan.plan)
    missing = [i for i in range(n) if records.get(i, {}).get("status") != "measured"]
    if missing:
        raise CalibrationError(f"{len(missing)} test pose visit(s) not measured: {missing[:10]}")
    pts = np.array([records[i]["point_mm"] for i in range(n)], float)
    rot = [records[i].get("rotvec_rad") for i in range(n)]
    rotvecs = np.array(rot, float) if all(r is not None for r in rot) else None
    return pts, rotvecs


def evaluate(
    pts_tracker: np.ndarray,
    rotvecs: np.ndarray | None,
    plan: VerifyPlan,
    registration: Registration,
) -> tuple[list[dict], pd.DataFrame]:
    """The figures per test pose and the attained-pose table, in the robot base frame.

    Parameters
    ----------
    pts_tracker : ndarray, shape (5 * cycles, 3)
        Tracker frame, mm.
    rotvecs : ndarray, shape (5 * cycles, 3), or None
        Probe orientation, tracker frame, rad (6-DoF probe only).

    Returns
    -------
    poses : list of dict
        One per test pose (1..5): ``test_pose``, ``AP_mm``, ``APx_mm``,
        ``APy_mm``, ``APz_mm``, ``RP_mm``, and with orientations
        ``APa_deg .. RPc_deg``.
    table : pandas.DataFrame
        :data:`COLUMNS`, one row per plan row (base frame, mm).
    """
    t2b = np.asarray(registration.tracker2base, float)
    base = pts_tracker @ t2b[:3, :3].T + t2b[:3, 3]
    commanded = plan.desired[plan.test_pose - 1, :3, 3]
    table = pd.DataFrame(
        {
            "test_pose": plan.test_pose.astype("int64"),
            "cycle": plan.cycle.astype("int64"),
            "x_mm": base[:, 0],
            "y_mm": base[:, 1],
            "z_mm": base[:, 2],
            "cmd_x_mm": commanded[:, 0],
            "cmd_y_mm": commanded[:, 1],
            "cmd_z_mm": commanded[:, 2],
        }
    )
    order = [np.flatnonzero(plan.test_pose == k) for k in range(1, 6)]
    # Figures from exactly the table's numbers, so anyone can recompute them from it.
    clouds = np.stack([table[["x_mm", "y_mm", "z_mm"]].to_numpy()[i] for i in order])
    cmds = np.stack([table[["cmd_x_mm", "cmd_y_mm", "cmd_z_mm"]].to_numpy()[i[0]] for i in order])
    figures = iso9283.position_figures(clouds, cmds)
    if rotvecs is not None:
        attained = t2b[:3, :3] @ rotations.rotvec_to_matrix(rotvecs)
        angles = rotations.angles_xyz(attained)
        for name, k in (("a_rad", 0), ("b_rad", 1), ("c_rad", 2)):
            table[name] = angles[:, k]
        cmd_angles = rotations.angles_xyz(plan.desired[:, :3, :3])
        figures.update(
            iso9283.orientation_figures(np.stack([angles[i] for i in order]), cmd_angles)
        )
    poses = []
    for k in range(5):
        entry: dict = {"test_pose": k + 1}
        entry.update({name: float(values[k]) for name, values in figures.items()})
        poses.append(entry)
    return poses, table


def document(
    plan: VerifyPlan, poses: list[dict], registration: Registration, *, info: dict
) -> dict:
    """The verify.json document (see docs/verify.md)."""
    measured = "APa_deg" in poses[0]
    return {
        "format": FORMAT,
        "version": VERSION,
        "standard": "ISO 9283 pose accuracy (AP) and pose repeatability (RP)",
        **info,
        "cycles": plan.cycles,
        "compensated": plan.compensated,
        "frame": "robot base",
        "registration": registration.to_json(),
        "cube": {
            "centre_mm": plan.shown(frames.transform(translation=plan.cube.centre_mm))[
                :3, 3
            ].tolist(),
            "side_mm": float(plan.cube.side_mm),
            "given": plan.cube_given,
        },
        "test_poses": [
            {
                "test_pose": k + 1,
                "commanded_mm": plan.shown(plan.desired[k])[:3, 3].tolist(),
                "rotation": plan.shown(plan.desired[k])[:3, :3].tolist(),
                "q_rad": plan.convention.to_controller(plan.q_test[k]).tolist(),
            }
            for k in range(5)
        ],
        "cycle_order": list(iso9283.CYCLE_ORDER),
        "orientation": "measured (6-DoF probe)"
        if measured
        else "not measured: the probe gives positions only (APa..RPc need a 6-DoF probe)",
        "poses": poses,
    }


def write(
    output: Path,
    records: dict,
    plan: VerifyPlan,
    registration: Registration | None,
    *,
    info: dict,
    inputs: list[Path],
) -> dict:
    """The figures of a finished run: ``output`` (JSON) and its :func:`data_path` (Parquet).

    Both files are written at once or neither (:mod:`calibrator.outputs`).

    Parameters
    ----------
    records : dict
        Journal records by plan row; every row must be measured.
    registration : Registration or None
        None: :func:`fit` on the attained positions.
    info : dict
        Fields of the document naming the devices, model and inputs.
    inputs : list of Path
        Files the outputs must not overwrite.

    Returns
    -------
    dict
        The verify.json document.

    Raises
    ------
    CalibrationError
        A visit not measured, or a non-finite figure (no certificate from it).
    """
    pts, rotvecs = points(records, plan)
    if registration is None:
        registration = fit(pts, plan)
    poses, table = evaluate(pts, rotvecs, plan, registration)
    doc = document(plan, poses, registration, info={**info, "data": data_path(output).name})
    try:
        with outputs.Outputs(inputs=inputs) as batch:
            batch.text(output, json.dumps(doc, indent=2, allow_nan=False) + "\n")
            batch.file(data_path(output), lambda tmp: table.to_parquet(tmp, index=False))
    except ValueError as exc:
        raise CalibrationError(f"cannot write {output}: {exc}") from None
    return doc
