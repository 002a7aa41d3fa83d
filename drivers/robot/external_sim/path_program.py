"""A controller running a path program: straight and circular moves at their stated speeds.

Reads a program ``calibrator program --path`` writes (KRL ``.src``, RAPID
``.mod``, URScript ``.script``, Fanuc LS ``.ls``) as a controller does: the joint move to the
start, the holds, and the linear and circular moves (through the via point to
the end point) at the stated path speed, with a trapezoidal speed profile
over each run of blended moves (stopping only at an exact-stop end). The
targets are the flange in the controller's base frame; the controller
solves them with its **nominal** model (:mod:`calibrator.model.inverse`)
and the hidden true arm runs those joints, so its true path strays from the
programmed one as a real uncalibrated arm's does.

Units: mm, s, rad (the programs' m/s, deg and quaternions are converted here).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from calibrator.model import frames, inverse, rotations
from drivers.robot.external_sim.motion import trapezoid_duration, trapezoid_fraction

#: Path acceleration of a language that states none (RAPID's ``AccSet 100, 100``, Fanuc's
#: ``ACC100``), mm/s^2.
DEFAULT_ACCEL_MM_S2 = 2000.0
#: Rate at which the controller's interpolation is sampled for the target's waypoints, Hz.
SAMPLE_HZ = 100.0


class ProgramError(ValueError):
    """A path program this controller cannot run (one line naming the file and line)."""


@dataclass(frozen=True)
class Move:
    """A linear (``via`` None) or circular move to ``end`` (flange, controller base, (4, 4))."""

    end: np.ndarray
    speed_mm_s: float
    accel_mm_s2: float
    blend: bool
    via: np.ndarray | None = None


@dataclass(frozen=True)
class Hold:
    seconds: float


@dataclass(frozen=True)
class PathProgram:
    """What the controller runs: the start joints (its own angles, rad), then holds and moves."""

    start_rad: np.ndarray
    steps: tuple


# ---------------------------------------------------------------- reading

_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _numbers(text: str) -> list[float]:
    return [float(v) for v in re.findall(_NUM, text)]


def read(path: str | Path) -> PathProgram:
    """The path program in ``path`` (by its extension: ``.src``, ``.mod``, ``.script``, ``.ls``).

    Raises
    ------
    ProgramError
        An unknown extension, or a statement a path program does not hold.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProgramError(f"{path}: cannot read it ({exc})") from None
    suffix = path.suffix.lower()
    readers = {
        ".src": _krl,
        ".mod": _rapid,
        ".script": _urscript,
        ".urscript": _urscript,
        ".ls": _fanuc,
    }
    if suffix not in readers:
        raise ProgramError(f"{path}: a path program is .src, .mod, .script or .ls, not {suffix!r}")
    return readers[suffix](text, str(path))


def _krl_frame(text: str) -> np.ndarray:
    values = dict(re.findall(rf"\b([XYZABC])\s+({_NUM})", text))
    if set(values) != set("XYZABC"):
        raise ValueError(f"a frame needs X, Y, Z, A, B, C: {text}")
    abc = [float(values[k]) for k in "ABC"]
    xyz = [float(values[k]) for k in "XYZ"]
    return frames.transform(rotations.zyx_to_matrix([abc])[0], xyz)


def _krl(text: str, name: str) -> PathProgram:
    start_axes: list[float] | None = None
    start = None
    speed = accel = None
    steps: list[Any] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split(";", 1)[0].strip()
        upper = line.upper()
        try:
            if not line or upper.startswith(("DEF ", "END", "DECL ", "$VEL_AXIS", "$ACC_AXIS")):
                continue
            if upper.startswith("START_POS"):
                values = dict(re.findall(rf"\bA(\d)\s+({_NUM})", line))
                start_axes = [float(values[str(i)]) for i in range(1, 7)]
            elif upper.startswith(("$TOOL", "$BASE")):
                if "$NULLFRAME" not in upper:
                    raise ValueError("this controller runs the flange in $ROBROOT only")
            elif upper.startswith("$VEL.CP"):
                speed = 1000.0 * _numbers(line.split("=", 1)[1])[0]
            elif upper.startswith("$ACC.CP"):
                accel = 1000.0 * _numbers(line.split("=", 1)[1])[0]
            elif upper.startswith(("$ORI_TYPE", "$CIRC_TYPE", "$APO.CDIS")):
                continue
            elif upper.startswith("PTP "):
                if start_axes is None or start is not None:
                    raise ValueError("one PTP START_POS, after its value")
                start = np.radians(start_axes)
            elif upper.startswith("WAIT SEC"):
                steps.append(Hold(_numbers(line[8:])[0]))
            elif upper.startswith(("LIN ", "CIRC ")):
                if speed is None or start is None:
                    raise ValueError("a path move before $VEL.CP or the PTP to the start")
                blend = upper.endswith("C_DIS")
                aggregates = re.findall(r"\{[^}]*\}", line)
                if len(aggregates) != (1 if upper.startswith("LIN") else 2):
                    raise ValueError("LIN takes one frame, CIRC two")
                poses = [_krl_frame(a) for a in aggregates]
                via = poses[0] if len(poses) == 2 else None
                steps.append(Move(poses[-1], speed, accel or DEFAULT_ACCEL_MM_S2, blend, via))
            else:
                raise ValueError(f"not a path program's statement: {line!r}")
        except (ValueError, IndexError, KeyError) as exc:
            raise ProgramError(f"{name}:{number}: {exc}") from None
    if start is None:
        raise ProgramError(f"{name}: no PTP to the path's start")
    return PathProgram(start, tuple(steps))


def _rapid_pose(text: str) -> np.ndarray:
    values = _numbers(text)
    pos, quat = values[:3], values[3:7]
    return frames.transform(rotations.quaternion_to_matrix([quat])[0], pos)


def _rapid(text: str, name: str) -> PathProgram:
    start = None
    speeds: dict[str, float] = {}
    joints: dict[str, list[float]] = {}
    steps: list[Any] = []
    # Statements end at ';' and may span lines; '!' starts a comment.
    body = "\n".join(line.split("!", 1)[0] for line in text.splitlines())
    for statement in body.split(";"):
        line = " ".join(statement.split())
        upper = line.upper()
        # MODULE, PROC and their ends take no ';': they lead the statement that follows.
        line = re.sub(
            r"^(?:(?:MODULE \w+|PROC \w+\(\)|ENDPROC|ENDMODULE)\s*)+", "", line, flags=re.I
        )
        upper = line.upper()
        try:
            if not line or upper.startswith("CONFL"):
                continue
            m = re.match(r"CONST (jointtarget|speeddata) (\w+) := (.*)", line, re.I)
            if m:
                values = _numbers(m.group(3))
                if m.group(1).lower() == "jointtarget":
                    joints[m.group(2).lower()] = values[:6]
                else:
                    speeds[m.group(2).lower()] = values[0]
                continue
            if upper.startswith("MOVEABSJ "):
                target = line.split()[1].rstrip(",").lower()
                if start is not None or target not in joints:
                    raise ValueError("one MoveAbsJ to a declared jointtarget")
                start = np.radians(joints[target])
            elif upper.startswith("WAITTIME"):
                steps.append(Hold(_numbers(line.split(",", 1)[1])[0]))
            elif upper.startswith(("MOVEL ", "MOVEC ")):
                circular = upper.startswith("MOVEC")
                literals = re.findall(r"\[\[[^;]*?\]\]", line)
                if len(literals) != (2 if circular else 1):
                    raise ValueError("MoveL takes one robtarget, MoveC two")
                tail = line[line.rfind("]]") + 2 :].strip(" ,").split(",")
                speed_name, zone, tool = (t.strip().lower() for t in tail[:3])
                if tool != "tool0" or speed_name not in speeds:
                    raise ValueError("a move with tool0 at a declared speeddata")
                poses = [_rapid_pose(lit) for lit in literals]
                via = poses[0] if circular else None
                blend = zone != "fine"
                steps.append(Move(poses[-1], speeds[speed_name], DEFAULT_ACCEL_MM_S2, blend, via))
            else:
                raise ValueError(f"not a path program's statement: {line!r}")
        except (ValueError, IndexError) as exc:
            raise ProgramError(f"{name}: {exc}") from None
    if start is None:
        raise ProgramError(f"{name}: no MoveAbsJ to the path's start")
    return PathProgram(start, tuple(steps))


def _urscript_pose(text: str) -> np.ndarray:
    x, y, z, rx, ry, rz = _numbers(text)
    return frames.transform(rotations.rotvec_to_matrix([rx, ry, rz]), [1e3 * x, 1e3 * y, 1e3 * z])


def _urscript(text: str, name: str) -> PathProgram:
    start = None
    steps: list[Any] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        try:
            if not line or line.startswith(("def ", "end", "set_tcp(p[0, 0, 0, 0, 0, 0])")):
                continue
            if re.fullmatch(r"\w+\(\)", line):
                continue  # the call of the program's def
            if line.startswith("start = ["):
                start = np.array(_numbers(line[line.index("[") :])[:6])
            elif line.startswith("movej(start"):
                if start is None:
                    raise ValueError("movej before the start's value")
            elif line.startswith("sleep("):
                steps.append(Hold(_numbers(line)[0]))
            elif line.startswith(("movel(", "movec(")):
                poses = [_urscript_pose(p) for p in re.findall(r"p\[([^\]]*)\]", line)]
                args = dict(re.findall(rf"\b(a|v|r)=({_NUM})", line))
                blend = float(args.get("r", 0.0)) > 0.0
                via = poses[0] if line.startswith("movec") else None
                speed, accel = 1e3 * float(args["v"]), 1e3 * float(args["a"])
                steps.append(Move(poses[-1], speed, accel, blend, via))
            else:
                raise ValueError(f"not a path program's statement: {line!r}")
        except (ValueError, IndexError, KeyError) as exc:
            raise ProgramError(f"{name}:{number}: {exc}") from None
    if start is None:
        raise ProgramError(f"{name}: no movej to the path's start")
    return PathProgram(start, tuple(steps))


def _fanuc(text: str, name: str) -> PathProgram:
    if "/MN" not in text or "/POS" not in text:
        raise ProgramError(f"{name}: a Fanuc LS program has /MN and /POS sections")
    main, rest = text.split("/MN", 1)[1].split("/POS", 1)
    positions: dict[int, Any] = {}
    for number, body in re.findall(r"P\[(\d+)(?::\"[^\"]*\")?\]\{(.*?)\};", rest, re.S):
        if "UF : 0, UT : 0" not in body:
            raise ProgramError(f"{name}: P[{number}]: this controller runs UF 0 and UT 0 only")
        joints = re.findall(rf"J\d= ({_NUM}) deg", body)
        if joints:
            positions[int(number)] = np.radians([float(v) for v in joints])
        else:
            v = {k: float(x) for k, x in re.findall(rf"\b([XYZWPR]) = ({_NUM})", body)}
            rot = rotations.zyx_to_matrix([[v["R"], v["P"], v["W"]]])[0]
            positions[int(number)] = frames.transform(rot, [v["X"], v["Y"], v["Z"]])
    # A statement is a numbered line and its ':' continuation lines.
    statements: list[str] = []
    for raw in main.splitlines():
        line = raw.strip()
        if re.match(r"\d+:", line):
            statements.append(line.split(":", 1)[1])
        elif line.startswith(":") and statements:
            statements[-1] += " " + line[1:]
    start = None
    steps: list[Any] = []
    for k, statement in enumerate(statements, start=1):
        line = " ".join(statement.rstrip("; ").split())
        try:
            refs = [int(n) for n in re.findall(r"P\[(\d+)", line)]
            if line.startswith(("UFRAME_NUM=0", "UTOOL_NUM=0")):
                continue
            if line.startswith("J "):
                if start is not None:
                    raise ValueError("one J move, to the start")
                start = positions[refs[0]]
            elif line.startswith("WAIT"):
                steps.append(Hold(_numbers(line)[0]))
            elif line.startswith(("L ", "C ")):
                speed = float(re.search(rf"({_NUM})mm/sec", line).group(1))  # type: ignore[union-attr]
                poses = [positions[n] for n in refs]
                via = poses[0] if line.startswith("C") else None
                blend = "CNT" in line
                steps.append(Move(poses[-1], speed, DEFAULT_ACCEL_MM_S2, blend, via))
            else:
                raise ValueError(f"not a path program's statement: {line!r}")
        except (ValueError, IndexError, KeyError, AttributeError) as exc:
            raise ProgramError(f"{name}: /MN line {k}: {exc}") from None
    if start is None:
        raise ProgramError(f"{name}: no J move to the path's start")
    return PathProgram(np.asarray(start), tuple(steps))


# ---------------------------------------------------------------- interpolating


def _arc(p0: np.ndarray, via: np.ndarray, p1: np.ndarray):
    """Centre (3,), radius, in-plane basis u, w (3,) each and swept angle of the arc p0-via-p1."""
    a, b = via - p0, p1 - p0
    n = np.cross(a, b)
    nn = float(n @ n)
    if nn < 1e-12:
        raise ProgramError("a circular move's points are on a line")
    centre = p0 + (np.cross(n, a) * (b @ b) + np.cross(b, n) * (a @ a)) / (2.0 * nn)
    radius = float(np.linalg.norm(p0 - centre))
    u = (p0 - centre) / radius
    w = np.cross(n / np.sqrt(nn), u)

    def angle(p: np.ndarray) -> float:
        d = p - centre
        return float(np.arctan2(d @ w, d @ u)) % (2.0 * np.pi)

    return centre, radius, u, w, angle(p1)


def _along_line(s: np.ndarray, a: np.ndarray, d: np.ndarray, n: float) -> np.ndarray:
    """Points (K, 3) ``s`` mm along the segment from ``a`` by ``d`` (length ``n``)."""
    return a + np.outer(s / max(n, 1e-12), d)


def _along_arc(s: np.ndarray, c: np.ndarray, r: float, u: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Points (K, 3) ``s`` mm along the arc about ``c`` of radius ``r`` from ``c + r u``."""
    th = (s / r)[:, None]
    return c + r * (np.cos(th) * u + np.sin(th) * w)


def _turn(r0: np.ndarray, r1: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """Rotations (K, 3, 3) turned from ``r0`` to ``r1`` by ``fraction`` (K,) of the way (slerp)."""
    axis = rotations.matrix_to_rotvec(r0.T @ r1)
    return r0 @ rotations.rotvec_to_matrix(np.outer(fraction, axis))


def _pieces(here: np.ndarray, moves: list[Move]):
    """Each move's geometry as ``(length, pose(s))`` (s mm from its start, poses (K, 4, 4)).

    The orientation turns from the move's start's to its end's along it
    (KRL ``$ORI_TYPE = #VAR``; the same at every target of a nominal program).
    """
    out = []
    for move in moves:
        end, r0, r1 = move.end[:3, 3], here[:3, :3], move.end[:3, :3]
        point: Callable[[np.ndarray], np.ndarray]
        if move.via is None:
            a = here[:3, 3].copy()
            length = float(np.linalg.norm(end - a))
            point = partial(_along_line, a=a, d=end - a, n=length)
        else:
            centre, radius, u, w, sweep = _arc(here[:3, 3], move.via[:3, 3], end)
            length = radius * sweep
            point = partial(_along_arc, c=centre, r=radius, u=u, w=w)

        def pose(s, point=point, r0=r0, r1=r1, n=length):
            out = np.broadcast_to(np.eye(4), (len(s), 4, 4)).copy()
            out[:, :3, :3] = _turn(r0, r1, s / max(n, 1e-12))
            out[:, :3, 3] = point(s)
            return out

        out.append((length, pose))
        here = move.end
    return out


def flange_path(program: PathProgram, start_pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The controller's flange over time: ``t`` (T,) s from the start, poses (T, 4, 4), mm.

    ``start_pose`` (4, 4) is the flange at the start joints (controller base).
    A run of blended moves is one motion with a trapezoidal speed profile at
    the first move's speed and acceleration; a hold keeps the last pose.
    """
    times, poses = [0.0], [np.asarray(start_pose, dtype=float)]
    t, here = 0.0, poses[0]
    run: list[Move] = []
    for step in (*program.steps, None):
        if isinstance(step, Move):
            run.append(step)
            if step.blend:
                continue
        if run:
            pieces = _pieces(here, run)
            total = sum(length for length, _ in pieces)
            speed, accel = run[0].speed_mm_s, run[0].accel_mm_s2
            duration = trapezoid_duration(total, speed, accel)
            tt = np.linspace(0.0, duration, max(int(np.ceil(duration * SAMPLE_HZ)), 1) + 1)[1:]
            s = trapezoid_fraction(tt, duration, speed, accel, total) * total
            starts = np.concatenate([[0.0], np.cumsum([length for length, _ in pieces])])
            k = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(pieces) - 1)
            p = np.empty((len(s), 4, 4))
            for i, (_, pose) in enumerate(pieces):
                mask = k == i
                p[mask] = pose(s[mask] - starts[i])
            times += list(t + tt)
            poses += list(p)
            t += duration
            here = run[-1].end
            run = []
        if isinstance(step, Hold):
            t += step.seconds
            times.append(t)
            poses.append(here)
    return np.array(times), np.array(poses)


def true_path(
    program: PathProgram,
    arm: Any,
    true_mdh: np.ndarray,
    flange2tool: np.ndarray,
    base2tracker: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The true reflector over time, tracker frame: ``t`` (T,) s and points (T, 3) mm.

    The controller of ``arm`` (its nominal model, joint convention and frames)
    solves each interpolated flange pose; the true arm (``true_mdh``, the
    true reflector ``flange2tool``, base placement ``base2tracker``) runs the joints.

    Raises
    ------
    ProgramError
        A target the nominal model cannot reach.
    """
    from calibrator.model import kinematics

    q_start = arm.convention.to_model(np.asarray(program.start_rad).reshape(1, 6))[0]
    base, flange = arm.model_base2controller_base, arm.model_flange2controller_flange
    start_pose = frames.invert(base) @ kinematics.chain(arm.mdh, q_start[None])[0] @ flange
    t, ctrl = flange_path(program, start_pose)
    model_poses = base @ ctrl @ frames.invert(flange)
    q = np.empty((len(t), 6))
    seed = q_start
    for lo in range(0, len(t), 200):  # seeded by the chunk before: the path's own solution
        chunk = model_poses[lo : lo + 200]
        sol = inverse.solve(
            arm.mdh, chunk, np.tile(seed, (len(chunk), 1)), None, arm.joint_limits_rad
        )
        if not np.all(sol.ok):
            raise ProgramError("the program leaves the nominal arm's reach")
        q[lo : lo + 200] = sol.q
        seed = sol.q[-1]
    points = kinematics.forward(true_mdh, q, flange2tool, base2tracker)[:, :3, 3]
    return t, points
