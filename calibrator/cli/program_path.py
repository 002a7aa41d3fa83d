"""``calibrator program --path``: the ISO 9283 test path as a robot program.

The path is the one ``calibrator verify --path`` commands with the same
options (:func:`calibrator.verify.path.plan_path` in the cube
:func:`calibrator.verify.pose.make_plan` places, the tool facing the tracker
when its position is known): the program states its straight and circular
moves (:mod:`calibrator.languages.path_program`), the controller
interpolates them, and ``verify --path --robot external`` measures the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from calibrator.languages import path_program as paths
from calibrator.languages.spec import ProgramSpec


@dataclass(frozen=True)
class PathRequest:
    """What ``program --path`` was asked for.

    Attributes
    ----------
    shape : str
        ``line``, ``circle`` or ``rectangle``.
    speed : calibrator.verify.path_procedure.Speed
        mm/s, or a percentage of the path's rated speed.
    cycles : int
    hold_s : float
        Wait at the path's ends, s (``--dwell``).
    cube : calibrator.verify.iso9283.Cube or None
        In the controller's base frame; None: the largest that fits.
    tool_mm : tuple of 3 floats or None
        The reflector on the flange, mm.
    tracker_at_mm : tuple of 3 floats or None
    cell : calibrator.cell.Cell or None
    calibration : calibrator.calibration.Calibration or None
        Compensate the targets with it (the path ``verify --path
        --calibration`` commands): the path is written as short moves
        (:data:`ARCS` arcs, straight moves of at most :data:`SEGMENT_MM`),
        each target corrected, the moves blended.
    """

    shape: str
    speed: Any
    cycles: int
    hold_s: float
    cube: Any = None
    tool_mm: Any = None
    tracker_at_mm: Any = None
    cell: Any = None
    calibration: Any = None


#: A compensated circle's arcs: the correction varies along the path, and a controller
#: interpolates a circle through three corrected points (its error shrinks as the arc's
#: square: about 4 um at 16 arcs of a 140 mm radius for a 1.5 mm correction).
ARCS = 16
#: Longest straight move of a compensated line or rectangle side, mm.
SEGMENT_MM = 20.0


def _plan(arm: Any, request: PathRequest) -> tuple[Any, float, float]:
    from calibrator.model import frames
    from calibrator.verify import path as verify_path
    from calibrator.verify import path_procedure, pose

    flange2tool = frames.transform(translation=_tool(request))
    vplan = pose.make_plan(
        arm, flange2tool, 2, request.cube, None, request.tracker_at_mm, request.cell
    )
    rotation = vplan.desired[0][:3, :3]
    args = (arm, flange2tool, request.shape, vplan.cube, rotation, vplan.q_test[0])
    rated = verify_path.rated_speed_mm_s(
        arm, verify_path.plan_path(*args, path_procedure.DEFAULT_SPEED_MM_S)
    )
    speed = request.speed
    if speed.percent:
        # Whole mm/s: the number verify --path-speed is then given, exactly as written.
        value = float(np.floor(speed.value / 100.0 * rated))
    else:
        value = float(speed.value)
    test = verify_path.plan_path(*args, value, request.calibration)
    return test, value, rated


def _tool(request: PathRequest) -> np.ndarray:
    from calibrator.verify import procedure

    tool = request.tool_mm if request.tool_mm is not None else procedure.Options().tool_mm
    return np.asarray(tool, dtype=float)


def path_spec(
    arm: Any,
    request: PathRequest,
    *,
    name: str,
    speed_rad_s: float,
    accel_rad_s2: float,
    fanuc: bool = False,
) -> tuple[paths.PathSpec, float, float]:
    """The path program of ``request`` for ``arm``, its speed and the path's rated speed (mm/s).

    Parameters
    ----------
    arm : calibrator.robots.RobotDescription
    request : PathRequest
    name : str
        The program's name.
    speed_rad_s, accel_rad_s2 : float
        Leading-joint caps of the joint move to the path's start.
    fanuc : bool
        The language states whole mm/s: the speed is rounded down to one.

    Raises
    ------
    CalibrationError
        A cube or path out of reach, a speed a program cannot state.
    """
    from calibrator.model import frames, kinematics
    from calibrator.verify import iso9283

    test, speed, rated = _plan(arm, request)
    if fanuc:
        speed = float(np.floor(speed + 1e-9))
    path = test.path
    s, moves, back = _targets(request.shape, path, request.calibration is not None)
    tool_poses = frames.transform(test.rotation, path.point(s))
    flange2tool = frames.transform(translation=_tool(request))
    # The joints along the planned path near each target: the solver's start, so every
    # target keeps the path's configuration.
    near = np.column_stack([np.interp(s / test.speed_mm_s, test.t_s, q) for q in test.q.T])
    from calibrator.errors import CalibrationError

    solution = iso9283.solve_poses(arm.mdh, tool_poses, flange2tool, arm.joint_limits_rad, near)
    if not np.all(solution.ok):
        raise CalibrationError(f"the {request.shape}'s targets leave the arm's reach")
    q = solution.q
    if request.calibration is not None:
        from calibrator import compensate

        # As verify --calibration commands it: the calibrated arm's joints at each target.
        result = compensate.compensate(
            request.calibration, desired=tool_poses, q_nominal=q, limits=arm.joint_limits_rad
        )
        if not np.all(result.solution.ok):
            raise CalibrationError(f"the calibrated arm cannot follow the {request.shape}")
        q = result.q
    # The controller's flange where its nominal model puts it at those joints.
    flange_model = kinematics.chain(arm.mdh, q)
    poses = (
        frames.invert(arm.model_base2controller_base)
        @ flange_model
        @ arm.model_flange2controller_flange
    )
    joints = ProgramSpec(
        plan_rad=q[:1],
        home_rad=q[0],
        speed_rad_s=speed_rad_s,
        accel_rad_s2=accel_rad_s2,
        max_joint_speed_rad_s=arm.max_joint_speed_rad_s,
        dwell_s=request.hold_s,
        name=name,
        model=arm.name,
        joint_limits_rad=arm.joint_limits_rad,
        convention=arm.convention,
        mdh=arm.mdh,
    )
    spec = paths.PathSpec(
        joints=joints,
        shape=request.shape,
        poses=poses,
        q_rad=q,
        moves=moves,
        back=back,
        speed_mm_s=speed,
        hold_s=request.hold_s,
        cycles=request.cycles,
        compensated=request.calibration is not None,
    )
    return spec, speed, rated


def _targets(shape: str, path: Any, fine: bool) -> tuple[np.ndarray, tuple, tuple]:
    """Arc lengths of the targets (mm), one cycle's moves and the way back.

    ``fine``: compensated targets, the path cut into :data:`ARCS` arcs or straight moves
    of at most :data:`SEGMENT_MM`, blended except at a rectangle's corners and the end.
    """
    from calibrator.verify import path_figures as ip

    length = path.length_mm
    if isinstance(path, ip.Circle):
        n = ARCS if fine else 2
        return np.arange(2 * n) / (2 * n) * length, paths.arcs(n), ()
    bounds = np.concatenate([[0.0], path.corner_s_mm, [length]])
    s = [0.0]
    moves = []
    for lo, hi in zip(bounds[:-1], bounds[1:], strict=True):
        n = int(np.ceil((hi - lo) / SEGMENT_MM)) if fine else 1
        for k in range(1, n + 1):
            s.append(lo + (hi - lo) * k / n)
            moves.append(paths.PathMove("line", len(s) - 1, blend=k < n))
    if shape == "line":
        return np.array(s), tuple(moves), (paths.PathMove("line", 0),)
    # A closed rectangle: its last target is its start.
    moves[-1] = paths.PathMove("line", 0)
    return np.array(s[:-1]), tuple(moves), ()
