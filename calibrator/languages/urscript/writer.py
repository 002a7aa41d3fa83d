"""URScript (Universal Robots, CB3 3.x and e-Series 5.x controllers): radians, ``movej``.

Load as a script file (``.script``) in a Script node or send it to the
controller's secondary interface; the program is one ``def``, indented by two
spaces, ``movej(q, a, v)`` with joint vectors in radians and the leading-joint
speed and acceleration in rad/s and rad/s^2, ``sleep(t)`` for the dwell and
``set_standard_digital_out(n, b)`` for the pulse. A via (moved through, not
measured) is a ``movej`` after a ``# via before pose i`` comment, with no sleep.
With Cartesian targets a pose's ``movej`` goes to ``p[x, y, z, rx, ry, rz]``
(m, rotation vector in rad): the nominal flange pose, which the controller
solves nearest the joints it comes from; where that may not be the plan's
solution, a joint move to the pose's joints comes first.
"""

from __future__ import annotations

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.languages.names import program_name, words
from calibrator.languages.path_program import PathSpec
from calibrator.languages.registry import writer
from calibrator.languages.spec import PULSE_S, ProgramSpec, number
from calibrator.languages.statements import between_homes, title
from calibrator.model import rotations

#: URScript's keywords and the names this program uses (case-sensitive).
RESERVED = words(
    "def end if elif else while for in return break continue thread run join kill global "
    "local and or not xor True False pass sec halt enter_critical exit_critical "
    "movej sleep set_standard_digital_out home movel movec set_tcp start",
    upper=False,
)


def _name(stem: str) -> str:
    return program_name(
        stem,
        language="URScript",
        reserved=RESERVED,
        max_length=63,
        same_as_file=False,
        case_sensitive=True,
    )


def _joints(spec: ProgramSpec, q) -> str:
    return "[" + ", ".join(spec.angles(q, "rad")) + "]"


def _target(spec: ProgramSpec, kind: str, start, q, move: str) -> str:
    """A move's statement: to joints, or (``cartesian`` poses) to ``p[x, y, z, rx, ry, rz]``.

    The pose is the nominal flange pose at the plan's joints, in m and rad (no
    ``set_tcp``: the program moves the flange). The controller solves it
    nearest the joints it comes from: where those are in another
    configuration, or a joint a half turn or more away (:func:`_needs_approach`),
    a joint move to the pose's own joints comes first, so the arm takes the
    path and configuration the plan checked.
    """
    if spec.targets != "cartesian" or kind != "pose":
        return f"  movej({_joints(spec, q)}, {move})"
    pose = spec.flange_pose(q)
    values = [*(pose[:3, 3] / 1000.0), *rotations.matrix_to_rotvec(pose[:3, :3])]
    # 1e-9 m and rad: far below any controller's resolution; + 0.0 turns -0.0 into 0.0.
    text = "p[" + ", ".join(f"{round(float(v), 9) + 0.0:.9f}" for v in values) + "]"
    approach = ""
    if _needs_approach(spec, start, q):
        approach = f"  movej({_joints(spec, q)}, {move})\n"
    return f"{approach}  movej({text}, {move})"


def _needs_approach(spec: ProgramSpec, start, q) -> bool:
    """Whether the solution nearest ``start`` (rad) may not be ``q``: another configuration,
    or a joint turned a half turn or more (the nearest solution is a whole turn off)."""
    from calibrator.languages import configuration

    assert spec.mdh is not None
    bits = configuration.arm_bits(spec.mdh, np.array([start, q], dtype=float))
    return bool(np.any(bits[0] != bits[1]) or np.any(np.abs(q - start) >= np.pi))


@writer(
    "urscript",
    (".script", ".urscript"),
    "URScript for UR controllers (CB3, e-Series); rad",
    _name,
)
def write(spec: ProgramSpec) -> str:
    if spec.pulse_output is not None and not 0 <= spec.pulse_output <= 7:
        raise CalibrationError(
            f"URScript's standard digital outputs are 0-7, not {spec.pulse_output}"
        )
    move = f"a={number(spec.accel_rad_s2)}, v={number(spec.speed_rad_s)}"
    lines = [
        f"# {spec.name}: {title(spec)}",
        "# joints in rad; speed and acceleration of the leading joint in rad/s and rad/s^2",
        *(
            ["# pose targets: the nominal flange pose p[x, y, z, rx, ry, rz] in m and rad"]
            if spec.targets == "cartesian"
            else []
        ),
        f"def {spec.name}():",
        f"  home = {_joints(spec, spec.home_rad)}",
        f"  movej(home, {move})",
    ]
    lines += between_homes(
        spec,
        move=lambda kind, pose, start, q: _target(spec, kind, start, q, move),
        pulse=lambda output: [
            f"  set_standard_digital_out({output}, True)",
            f"  sleep({PULSE_S:.3f})",
            f"  set_standard_digital_out({output}, False)",
        ],
        dwell=lambda wait: f"  sleep({wait:.3f})",
        comment=lambda text: f"  # {text}",
        pulse_blocks=True,  # sleep() waits the pulse out
    )
    lines += [f"  movej(home, {move})", "end", f"{spec.name}()", ""]
    return "\n".join(lines)


#: Blend radius of a blended move (a circle's two arcs meet tangentially), m.
BLEND_M = 0.001


def _pose(spec: PathSpec, k: int) -> str:
    """Target ``k`` as ``p[x, y, z, rx, ry, rz]``: m and a rotation vector in rad."""
    values = [*(spec.position(k) / 1000.0), *rotations.matrix_to_rotvec(spec.rotation(k))]
    return "p[" + ", ".join(f"{round(float(v), 9) + 0.0:.9f}" for v in values) + "]"


def write_path(spec: PathSpec) -> str:
    """The path program in URScript: ``movej`` to the start, ``movel`` and ``movec``.

    ``v`` is the tool speed in m/s and ``a`` its acceleration in m/s^2;
    ``movec(via, to, ...)`` moves through the via pose to the end pose
    (``mode=0``: the orientation of the end pose, the same at every target).
    ``set_tcp`` of the zero pose makes the targets the flange's, in the base
    frame. A blended move has ``r`` (m), the others stop at their end.
    """
    joints = spec.joints
    approach = f"a={number(joints.accel_rad_s2)}, v={number(joints.speed_rad_s)}"
    path = f"a={number(spec.accel_mm_s2 / 1000.0)}, v={number(spec.speed_mm_s / 1000.0)}"
    lines = [
        f"# {spec.name}: ISO 9283 {spec.shape} path, {spec.cycles} cycles at "
        f"{spec.speed_mm_s:g} mm/s" + (f" for {joints.model}" if joints.model else ""),
        "# joints in rad; targets: the flange p[x, y, z, rx, ry, rz] in the base frame, m and rad;",
        "# path speed and acceleration in m/s and m/s^2",
        f"def {spec.name}():",
        "  set_tcp(p[0, 0, 0, 0, 0, 0])",
        f"  start = {_joints(joints, joints.home_rad)}",
        f"  movej(start, {approach})",
    ]
    for _step, move in spec.steps():
        if move is None:
            lines.append(f"  sleep({spec.hold_s:.3f})")
            continue
        blend = f", r={BLEND_M:g}" if move.blend else ""
        if move.kind == "line":
            lines.append(f"  movel({_pose(spec, move.end)}, {path}{blend})")
        else:
            assert move.via is not None
            via, end = _pose(spec, move.via), _pose(spec, move.end)
            lines.append(f"  movec({via}, {end}, {path}{blend}, mode=0)")
    lines += ["end", f"{spec.name}()", ""]
    return "\n".join(lines)
