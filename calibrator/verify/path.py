"""The ISO 9283 path test: a line, a circle or a rectangle in the test cube, streamed.

The pose test (:mod:`calibrator.verify.pose`) stops at five poses; this
runs a path through the same cube and measures it continuously:

1. the commanded path (:func:`test_path`) lies in the cube's test plane:
   the ``line`` from P2 to P4 (along the cube's space diagonal, through P1)
   or the ``circle`` about P1 in that plane, of radius
   :data:`CIRCLE_RADIUS_FRACTION` of the edge, tool orientation constant as
   in the pose test;
2. the controller's joint commands are those of the path's points at
   :data:`CONTROL_HZ` at the commanded speed, and at every corner (nominal inverse kinematics,
   or compensated with a calibration: what the controller would
   interpolate);
3. the robot runs them (:data:`calibrator.acquire.ports.FOLLOW_PATH`: the
   simulated arm turns them into its probe's true path in the tracker frame,
   which the tracker simulator follows, ``SIM,PATH``) while the tracker
   streams it (``STREAM``);
4. each cycle's stream goes into the robot base frame through the
   registration, is aligned in time (:func:`calibrator.verify.path_figures.estimate_latency`)
   and the clause 7 figures are computed from the ``cycles`` streams: position
   always, orientation (``ATa``..``RTc``) when the tracker's probe streams its
   orientation (a 6-DoF probe); a reflector's orientation figures are None. A
   robot that records its actual joints while it runs the path
   (:class:`StreamsJoints`: a UR over RTDE) is aligned robot stream to tracker
   stream (:func:`stream_cycle_robot`: the tracker's latency behind the arm);
   any other is aligned tracker-only, against the path run at constant speed
   (:func:`stream_cycle`).

The simulated arm is kinematic (it follows its commands exactly, no
servo lag), so corners show no overshoot; its path error is the geometric
error a calibration removes. Units: mm, s, rad.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt
import pandas as pd
from scipy.optimize import minimize_scalar

from calibrator import compensate
from calibrator.acquire import ports
from calibrator.errors import CalibrationError
from calibrator.model import frames, rotations
from calibrator.verify import iso9283
from calibrator.verify import path_figures as ip

#: Rate at which the controller's interpolated joint commands are taken, Hz.
CONTROL_HZ = 250.0
#: Tracker stream rate, Hz.
STREAM_HZ = 500
#: Radius of the test circle as a fraction of the cube's edge (it stays in the plane).
CIRCLE_RADIUS_FRACTION = 0.3
#: The target holds this long at the path's ends, s: the stream starts before the
#: motion and ends after it, so the alignment sees both ends.
HOLD_S = 0.3
#: Calculated points per path (clause 7.2's m).
POINTS = 100
#: Part of the path (of a rectangle's first side) on which the speed is taken as constant
#: (7.6), as fractions of its length.
SPEED_STRETCH = (0.1, 0.9)
#: Speed chord, samples of the stream (20 ms at 500 Hz): the tracker's noise over a
#: 2 ms chord alone would swing the speed by several mm/s.
SPEED_STEP = 10
SHAPES = ("line", "circle", "rectangle")
#: Columns of the recorded streams (verify.parquet beside a path test's verify.json).
STREAM_COLUMNS = ("cycle", "n", "t_s", "x_mm", "y_mm", "z_mm")
#: Columns the streams gain from a 6-DoF probe: the attained orientation's angles
#: (:func:`calibrator.model.rotations.angles_xyz`, base frame, rad), as verify's pose table.
ORIENTATION_COLUMNS = ("a_rad", "b_rad", "c_rad")
#: The clause 7 orientation figures, keys of the ``path`` section (degrees; None from a
#: reflector, which gives positions only).
ORIENTATION_FIGURES = ("ATa_deg", "ATb_deg", "ATc_deg", "RTa_deg", "RTb_deg", "RTc_deg")
#: Keep the calculated points this far from a rectangle's corners, mm (7.2 at the corners
#: is 7.5's business).
CORNER_MARGIN_MM = 5.0


@runtime_checkable
class PathTracker(Protocol):
    """What the path test needs of its tracker: a stream to read."""

    def stream(
        self, rate_hz: int, count: int | None = None, *, stall_timeout_s: float | None = None
    ) -> Any: ...


@runtime_checkable
class StreamsJoints(Protocol):
    """A robot that records its actual joints while it runs a path (a UR over RTDE).

    ``joint_stream()``, after ``follow_path``, waits for the path's end and
    returns its record: ``t_s`` (R,) controller timestamps, s; ``q_rad`` (R, 6),
    rad; ``host_offset_s`` (host monotonic time = ``t_s + host_offset_s``) and
    ``start_host_s`` (the commanded start, host monotonic time, s).
    """

    def joint_stream(self) -> Any: ...


#: ``alignment`` of a path section: robot stream to tracker stream, or tracker-only.
ALIGN_ROBOT = "robot stream"
ALIGN_TRACKER = "tracker only"
#: Largest latency of the tracker behind the robot's stream looked for, either sign, s.
MAX_LATENCY_S = 0.25
#: How far from the plain latency the one with the mean offset out is looked for, s
#: (a model error of 2 mm along the path at 40 mm/s), and the grid step there, s.
OFFSET_WINDOW_S = 0.05
OFFSET_GRID_S = 0.0005


@dataclass(frozen=True)
class PathTest:
    """A commanded path test.

    Attributes
    ----------
    shape : str
        ``line`` or ``circle``.
    path : Polyline or Circle
        Commanded path, robot base frame (the model's), mm.
    rotation : ndarray, shape (3, 3)
        Constant tool orientation, base frame.
    speed_mm_s : float
        Commanded path speed.
    t_s : ndarray, shape (N,)
        Command times from the start of the motion, s.
    q : ndarray, shape (N, 6)
        Joint commands at ``t_s``, rad (the model's).
    compensated : bool
    """

    shape: str
    path: ip.CommandedPath
    rotation: np.ndarray
    speed_mm_s: float
    t_s: np.ndarray
    q: np.ndarray
    compensated: bool


def test_path(shape: str, cube: iso9283.Cube, rotation: npt.ArrayLike) -> ip.CommandedPath:
    """The commanded ``line`` (P2 to P4), ``circle`` (about P1) or ``rectangle``
    (P2, P3, P4, P5 and back) in the cube's test plane, base frame, mm."""
    p = iso9283.test_positions(cube.centre_mm, cube.side_mm)
    if shape == "line":
        return ip.line(p[1], p[3])
    if shape == "circle":
        # The plane holds P2..P5: its normal is across the two diagonals.
        normal = np.cross(p[1] - p[3], p[2] - p[4])
        return ip.circle(p[0], normal, CIRCLE_RADIUS_FRACTION * cube.side_mm, p[1] - p[0])
    if shape == "rectangle":
        # P2..P5 are the corners of a rectangle in the plane (10 % in from its corners).
        return ip.rectangle(p[1:5])
    raise CalibrationError(f"--path must be one of {', '.join(SHAPES)}, got {shape!r}")


def plan_path(
    model: Any,
    flange2tool: npt.ArrayLike,
    shape: str,
    cube: iso9283.Cube,
    rotation: npt.ArrayLike,
    q_start: npt.ArrayLike,
    speed_mm_s: float,
    calibration: Any = None,
) -> PathTest:
    """Joint commands along the test path at ``speed_mm_s`` (nominal IK, or compensated).

    Raises
    ------
    CalibrationError
        A point of the path out of reach.
    """
    path = test_path(shape, cube, rotation)
    return plan_along(model, flange2tool, shape, path, rotation, q_start, speed_mm_s, calibration)


def plan_along(
    model: Any,
    flange2tool: npt.ArrayLike,
    shape: str,
    path: ip.CommandedPath,
    rotation: npt.ArrayLike,
    q_start: npt.ArrayLike,
    speed_mm_s: float,
    calibration: Any = None,
) -> PathTest:
    """Joint commands along a given commanded ``path`` (base frame, mm) at ``speed_mm_s``.

    As :func:`plan_path`, for a path of the caller's (the circle test's two directions).

    Raises
    ------
    CalibrationError
        A point of the path out of reach.
    """
    if not speed_mm_s > 0:
        raise CalibrationError(f"--path-speed must be > 0 mm/s, got {speed_mm_s}")
    duration = path.length_mm / speed_mm_s
    t = np.linspace(0.0, duration, max(int(np.ceil(duration * CONTROL_HZ)), 1) + 1)
    # A command at every corner: between two samples either side the arm would cut it.
    # A tick within a microsecond of a corner is dropped: the simulator (as a controller)
    # refuses waypoints whose times do not increase on its microsecond clock.
    corners_s = path.corner_s_mm / speed_mm_s
    if len(corners_s):
        t = t[np.abs(t[:, None] - corners_s[None, :]).min(axis=1) > 1e-6]
    t = np.union1d(t, corners_s)
    rot = np.asarray(rotation, dtype=float)
    desired = frames.transform(rot, path.point(speed_mm_s * t))
    limits = model.joint_limits_rad
    solution = iso9283.solve_poses(model.mdh, desired, flange2tool, limits, q_start)
    if not np.all(solution.ok):
        raise CalibrationError(f"the {shape} leaves the arm's reach: choose a smaller --cube")
    q = solution.q
    if calibration is not None:
        result = compensate.compensate(calibration, desired=desired, q_nominal=q, limits=limits)
        if not np.all(result.solution.ok):
            raise CalibrationError(f"the calibrated arm cannot follow the {shape}")
        q = result.q
    return PathTest(shape, path, rot, float(speed_mm_s), t, q, calibration is not None)


def run(
    robot: ports.FollowsPath,
    tracker: PathTracker,
    test: PathTest,
    cycles: int,
    tracker2base: npt.ArrayLike,
    tool_points: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[dict, pd.DataFrame]:
    """Run ``cycles`` cycles of the path and compute the figures.

    Parameters
    ----------
    robot : calibrator.acquire.ports.FollowsPath
        The connected arm that runs the joint path.
    tracker : PathTracker
        The connected tracker that streams it.
    test : PathTest
    cycles : int
        At least 2 (RT and RV need a spread).
    tracker2base : array_like, shape (4, 4)
        Registration of the tracker frame in the robot base frame, mm.
    tool_points : callable, optional
        ``tool_points(q)``: the model's (nominal or calibrated) tool positions,
        (R, 3) base frame, mm, at joints (R, 6), rad. With it, a robot that
        streams its joints (:class:`StreamsJoints`) is aligned robot stream to
        tracker stream; otherwise (or without it) tracker-only.

    Returns
    -------
    section : dict
        The ``path`` section of verify.json (see :func:`figures`), with
        ``alignment`` and, for a robot stream, ``latency_s`` per cycle.
    streams : pandas.DataFrame
        The aligned streams, :data:`STREAM_COLUMNS`: cycle (from 1), tick
        number, time from the aligned start (s), position (base frame, mm);
        and :data:`ORIENTATION_COLUMNS` when the probe gives its orientation.
    """
    if cycles < 2:
        raise CalibrationError(f"--cycles must be at least 2, got {cycles}")
    t2b = np.asarray(tracker2base, dtype=float)
    streams, starts, ticks, latencies = [], [], [], []
    reference = ip.commanded_reference(test.path, test.speed_mm_s)
    by_robot = tool_points is not None and isinstance(robot, StreamsJoints)
    for _ in range(cycles):
        if by_robot:
            assert tool_points is not None and isinstance(robot, StreamsJoints)
            one, start, tick, latency = stream_cycle_robot(robot, tracker, test, t2b, tool_points)
            latencies.append(latency)
        else:
            one, start, tick = stream_cycle(robot, tracker, test, t2b, reference)
        streams.append(one)
        starts.append(start)
        ticks.append(tick)
    columns = {
        "cycle": np.repeat(np.arange(1, cycles + 1), [len(st.t_s) for st in streams]),
        "n": np.concatenate(ticks),
        "t_s": np.concatenate([st.t_s for st in streams]),
        **{
            f"{axis}_mm": np.concatenate([st.p_mm[:, k] for st in streams])
            for k, axis in enumerate("xyz")
        },
    }
    angles = [st.abc_rad for st in streams if st.abc_rad is not None]
    oriented = len(angles) == len(streams)
    if oriented:
        columns.update(
            {
                name: np.concatenate([a[:, k] for a in angles])
                for k, name in enumerate(ORIENTATION_COLUMNS)
            }
        )
    names = list(STREAM_COLUMNS) + (list(ORIENTATION_COLUMNS) if oriented else [])
    table = pd.DataFrame(columns, columns=names)
    section = figures(test, streams, starts, cycles)
    section["alignment"] = ALIGN_ROBOT if by_robot else ALIGN_TRACKER
    if by_robot:
        section["latency_s"] = [float(v) for v in latencies]
    return section, table


def stream_cycle(
    robot: ports.FollowsPath,
    tracker: PathTracker,
    test: PathTest,
    tracker2base: npt.ArrayLike,
    reference: Callable[[np.ndarray], np.ndarray] | None = None,
) -> tuple[ip.Stream, float, np.ndarray]:
    """One run of the path, streamed and aligned to the command.

    Parameters
    ----------
    robot : calibrator.acquire.ports.FollowsPath
        Runs ``test.q`` at ``test.t_s``.
    tracker : PathTracker
    test : PathTest
    tracker2base : array_like, shape (4, 4)
        Registration, mm.
    reference : callable, optional
        The alignment's reference (default the commanded path's timing,
        :func:`calibrator.verify.path_figures.commanded_reference`).

    Returns
    -------
    stream : calibrator.verify.path_figures.Stream
        The attained path from the aligned start of the motion to its end, base frame,
        mm; with its orientations (angles, base frame, rad) when the probe gives them.
    start : float
        Found start less the one requested, s.
    ticks : ndarray, shape (K,)
        The tracker's reading numbers of the stream's samples.
    """
    t2b = np.asarray(tracker2base, dtype=float)
    if reference is None:
        reference = ip.commanded_reference(test.path, test.speed_mm_s)
    duration = float(test.t_s[-1])
    count = int(np.ceil((duration + 2 * HOLD_S) * STREAM_HZ))
    told_us = robot.follow_path(test.t_s, test.q, delay_s=HOLD_S)
    # A stream silent for STALL_S is broken; a shorter gap is a busy host (the simulated
    # tracker shares the computer with the run: on a loaded CI machine it fell 0.5 s
    # behind), and its ticks are counted as they come.
    with tracker.stream(STREAM_HZ, count=count, stall_timeout_s=STALL_S) as stream:
        rec = stream.collect(count)
    ok = rec.code == 0
    if rec.rotvec_rad is not None:  # a 6-DoF tick without its orientation is no tick
        ok &= np.all(np.isfinite(rec.rotvec_rad), axis=1)
    if ok.sum() < 0.9 * count:
        raise CalibrationError(
            f"the tracker streamed {int(ok.sum())} of {count} readings of the path"
        )
    # Times from where the simulator was told to start; the alignment finds the
    # true start on the tracker's clock (its latency included) from the data alone.
    t = (rec.t_us[ok] - told_us) / 1e6
    p = rec.point_mm[ok] @ t2b[:3, :3].T + t2b[:3, 3]
    start = ip.estimate_latency(t, p, reference, max_latency_s=HOLD_S)
    inside = (t >= start) & (t <= start + duration)
    abc = None
    if rec.rotvec_rad is not None:
        abc = _base_angles(t2b, rec.rotvec_rad[ok][inside])
    stream = ip.Stream(t[inside] - start, p[inside], abc)
    return stream, float(start), rec.n[ok][inside]


def _base_angles(tracker2base: np.ndarray, rotvec_rad: np.ndarray) -> np.ndarray:
    """Probe orientations (probe to tracker, rotation vectors (K, 3), rad) as the
    base-frame angles a, b, c (K, 3), rad, read as verify's pose test reads them."""
    return rotations.angles_xyz(tracker2base[:3, :3] @ rotations.rotvec_to_matrix(rotvec_rad))


def stream_cycle_robot(
    robot: Any,
    tracker: PathTracker,
    test: PathTest,
    tracker2base: npt.ArrayLike,
    tool_points: Callable[[np.ndarray], np.ndarray],
) -> tuple[ip.Stream, float, np.ndarray, float]:
    """One run of the path, aligned robot stream to tracker stream.

    Both streams go onto the host's monotonic clock, each by the smallest gap
    seen between a sample's arrival and its own stamp (the robot's
    ``host_offset_s``; the tracker's from the arrival of its ticks), from the
    commanded start. The robot's actual joints through the model
    (``tool_points``) give its timed tool path: the arm's own start is where
    that path best fits the command run at constant speed, and the tracker's
    latency is where the tracker's points best fit that path
    (:func:`robot_latency`).

    Parameters
    ----------
    robot : FollowsPath and StreamsJoints
    tracker : PathTracker
    test : PathTest
    tracker2base : array_like, shape (4, 4)
        Registration, mm.
    tool_points : callable
        Joints (R, 6), rad -> tool positions (R, 3), base frame, mm.

    Returns
    -------
    stream : calibrator.verify.path_figures.Stream
        The attained path from the arm's start of the motion to its end (the
        robot's time), base frame, mm.
    start : float
        The arm's start less the commanded one, s (its lag behind the command).
    ticks : ndarray, shape (K,)
        The tracker's reading numbers of the stream's samples.
    latency : float
        The tracker's stamps behind the arm's, s.
    """
    t2b = np.asarray(tracker2base, dtype=float)
    duration = float(test.t_s[-1])
    # The stream starts once the path is handed over, the motion ROBOT_LEAD_S later:
    # a stream that starts up to that late on a busy host still sees both ends.
    count = int(np.ceil((duration + 2 * ROBOT_LEAD_S) * STREAM_HZ))
    robot.follow_path(test.t_s, test.q, delay_s=ROBOT_LEAD_S)
    try:
        with tracker.stream(STREAM_HZ, count=count, stall_timeout_s=STALL_S) as stream:
            n, t_us, p_tracker, code, seen, rotvec = timed_samples(stream, count)
    except BaseException:
        # The arm is on its way: a stream that failed (or Ctrl-C) stops it; what
        # the caller hears about is the failure, not a stop that failed too.
        with contextlib.suppress(Exception):
            robot.stop()
        raise
    record = robot.joint_stream()
    ok = code == 0
    if ok.sum() < 0.9 * count:
        raise CalibrationError(
            f"the tracker streamed {int(ok.sum())} of {count} readings of the path"
        )
    if len(record.t_s) < 2:
        raise CalibrationError("the robot streamed no joints while it ran the path")
    start_host = float(record.start_host_s)
    t_k = t_us[ok] / 1e6 + float(np.min(seen - t_us / 1e6)) - start_host
    p_k = p_tracker[ok] @ t2b[:3, :3].T + t2b[:3, 3]
    t_r = np.asarray(record.t_s, float) + float(record.host_offset_s) - start_host
    p_r = tool_points(np.asarray(record.q_rad, float))
    command = ip.commanded_reference(test.path, test.speed_mm_s)
    start = ip.estimate_latency(t_r, p_r, command, max_latency_s=HOLD_S)
    latency = robot_latency(t_k, p_k, ip.stream_reference(t_r, p_r))
    t = t_k - latency - start
    inside = (t >= 0.0) & (t <= duration)
    abc = None
    if rotvec is not None:
        abc = _base_angles(t2b, rotvec[ok][inside])
    return ip.Stream(t[inside], p_k[inside], abc), float(start), n[ok][inside], float(latency)


def robot_latency(t_s: np.ndarray, p_mm: np.ndarray, reference: ip.Reference) -> float:
    """The tracker's latency behind the robot's path, with their mean offset taken out.

    The robot's path is its model's (nominal or calibrated), the tracker's
    the true arm's: a model error along the path would pass for a time shift
    (0.5 mm at 100 mm/s is 5 ms). So the latency minimises the spread of the
    differences about their mean, ``sum_k |d_k - dbar|^2`` with
    ``d_k = p_k - reference(t_k - tau)``: the holds before and after the
    motion and its start and stop fix the time, any constant offset is left
    out. It is looked for within :data:`OFFSET_WINDOW_S` of the plain least
    squares latency (:func:`calibrator.verify.path_figures.estimate_latency`),
    on a grid of :data:`OFFSET_GRID_S`, then refined.

    Parameters
    ----------
    t_s : ndarray, shape (K,)
        Tracker stamps on the robot stream's time axis, s.
    p_mm : ndarray, shape (K, 3)
        Tracker points, base frame, mm.
    reference : callable
        The robot's path at any time (:func:`calibrator.verify.path_figures.stream_reference`).

    Returns
    -------
    float
        Latency, s: a reading stamped ``t`` shows the arm as it was at ``t - latency``.
    """
    plain = ip.estimate_latency(t_s, p_mm, reference, MAX_LATENCY_S)

    def spread(tau: float) -> float:
        d = p_mm - reference(t_s - tau)
        return float(((d - d.mean(axis=0)) ** 2).sum())

    grid = plain + np.arange(-OFFSET_WINDOW_S, OFFSET_WINDOW_S + 1e-12, OFFSET_GRID_S)
    best = int(np.argmin([spread(tau) for tau in grid]))
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
    found = minimize_scalar(spread, bounds=(lo, hi), method="bounded", options={"xatol": 1e-7})
    return float(found.x)


def timed_samples(
    stream: Any, count: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]:
    """Up to ``count`` ticks of a tracker stream, with when each reached this host.

    Returns
    -------
    n, t_us, point_mm, code, seen : ndarray
        Tick numbers (K,); tracker stamps (K,), us; points (K, 3), tracker
        frame, mm, NaN without a reading; codes (K,), 0 with a reading; host
        monotonic time each tick was handed over (K,), s.
    rotvec_rad : ndarray, shape (K, 3), or None
        The probe's orientations (probe to tracker frame), NaN without a
        reading; None when no reading carries one (a reflector).
    """
    n, t_us, code, seen, points, turns = [], [], [], [], [], []
    for sample in stream:
        seen.append(time.monotonic())
        n.append(sample.n)
        t_us.append(sample.device_time_us)
        code.append(sample.code)
        reading = sample.reading
        points.append(reading.point_mm if reading is not None else np.full(3, np.nan))
        turn = getattr(reading, "rotvec_rad", None)
        turns.append(turn if turn is not None else np.full(3, np.nan))
        if len(n) >= count:
            break
    rotvec = np.array(turns, dtype=float).reshape(-1, 3)
    return (
        np.array(n, dtype=np.int64),
        np.array(t_us, dtype=np.int64),
        np.array(points, dtype=float).reshape(-1, 3),
        np.array(code, dtype=np.int64),
        np.array(seen, dtype=float),
        rotvec if np.isfinite(rotvec).any() else None,
    )


#: How long the tracker's stream may stay silent before the run calls it broken, s.
STALL_S = 5.0
#: A robot that streams its joints (a UR) starts the path this long after it is handed
#: the path, and holds its end as long, s: the tracker's stream, started after the
#: hand-over, must see the whole motion even when the host is slow to start it (at
#: HOLD_S, a stream started 0.3 s late on a loaded machine missed the path's end).
ROBOT_LEAD_S = 1.0


def rated_speed_mm_s(model: Any, test: PathTest) -> float:
    """The path's rated speed: the fastest constant tool speed within the motion ceilings.

    ISO 9283 states its speeds as 100, 50 and 10 % of the rated speed, which a
    manufacturer's sheet gives; here it comes from the description's motion
    ceilings: every joint ``j`` may turn at most
    ``min(model.move_speed_cap_rad_s, model.max_joint_speed_rad_s[j])``. Joint
    speeds scale with the tool speed along a fixed path, so the rated speed is
    ``test.speed_mm_s`` times the smallest ratio of a joint's ceiling to its
    peak speed along ``test`` (finite differences of the commands).

    Parameters
    ----------
    model : calibrator.robots.RobotDescription
    test : PathTest
        The path planned at any speed.

    Returns
    -------
    float
        Rated tool speed along this path, mm/s.
    """
    ceiling = np.minimum(model.move_speed_cap_rad_s, np.asarray(model.max_joint_speed_rad_s))
    dt = np.diff(test.t_s)
    keep = dt > 1e-9  # a corner's command can fall within a nanosecond of a tick
    speeds = np.abs(np.diff(test.q, axis=0)[keep] / dt[keep, None])
    peak = speeds.max(axis=0)
    ratio = np.where(peak > 0, ceiling / np.where(peak > 0, peak, 1.0), np.inf)
    return float(test.speed_mm_s * ratio.min())


def figures(test: PathTest, streams: list, starts: list, cycles: int) -> dict:
    """The ``path`` section: commanded path, the clause 7 figures, per-point accuracy."""
    corners = isinstance(test.path, ip.Polyline) and len(test.path.corner_s_mm) > 0
    margin = CORNER_MARGIN_MM if corners else 0.0
    # The commanded orientation is constant along the path (the pose test's P1).
    commanded_abc = rotations.angles_xyz(test.rotation)
    pf = ip.path_figures(
        test.path, streams, m=POINTS, margin_mm=margin, commanded_abc_rad=commanded_abc
    )
    # The speed on a straight stretch away from the start, the stop and any corner:
    # the first segment of a rectangle (a chord across a corner is shorter than the path).
    first = test.path.corner_s_mm[0] if corners else test.path.length_mm
    lo, hi = (f * first for f in SPEED_STRETCH)
    vf = ip.velocity_figures(
        test.path, streams, test.speed_mm_s, stretch_mm=(lo, hi), step=SPEED_STEP
    )
    if isinstance(test.path, ip.Circle):
        commanded = {
            "centre_mm": test.path.centre_mm.tolist(),
            "normal": test.path.normal.tolist(),
            "radius_mm": test.path.radius_mm,
        }
    else:
        commanded = {"vertices_mm": test.path.vertices_mm.tolist()}
    extra: dict = {}
    if corners:
        assert isinstance(test.path, ip.Polyline)
        cf = ip.corner_figures(test.path, streams)
        extra = {
            "CR_mm": cf["CR_max_mm"].tolist(),
            "CO_mm": cf["CO_max_mm"].tolist(),
            "corners_mm": test.path.vertices_mm[1:-1].tolist(),
        }
    return {
        "shape": test.shape,
        "frame": "robot base (the model's)",
        "commanded": {
            **commanded,
            "length_mm": test.path.length_mm,
            "abc_deg": np.rad2deg(commanded_abc).tolist(),  # the tool's, all along
        },
        "speed_mm_s": test.speed_mm_s,
        "cycles": cycles,
        "compensated": test.compensated,
        "stream_hz": STREAM_HZ,
        "speed_chord_s": SPEED_STEP / STREAM_HZ,
        "AT_P_mm": pf["AT_P_mm"],
        "RT_P_mm": pf["RT_P_mm"],
        "AV_pct": vf["AV_pct"],
        "RV_pct": vf["RV_pct"],
        "FV_mm_s": vf["FV_mm_s"],
        "points": {
            "s_mm": pf["s_mm"].tolist(),
            "AT_mm": pf["AT_i_mm"].tolist(),
            "RT_mm": pf["RT_i_mm"].tolist(),
        },
        "start_s": [float(s) for s in starts],  # found start less the one requested
        # Clause 7's orientation figures need a 6-DoF probe; a reflector's are None.
        "orientation": (
            "measured (6-DoF probe)"
            if "ATa_deg" in pf
            else "not measured: the probe gives positions only (ATa..RTc need a 6-DoF probe)"
        ),
        **{name: pf.get(name) for name in ORIENTATION_FIGURES},
        **extra,
    }
