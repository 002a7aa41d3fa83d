"""RAPID (ABB IRC5 with RobotWare 6.x, OmniCore with RobotWare 7.x): degrees, ``MoveAbsJ``.

Load the ``.mod`` module into the task (it holds ``PROC main``). Joint
targets are ``jointtarget`` literals (robot axes in degrees, external axes
``9E9``: none). Each move is time-programmed (``\\T``) to the duration a
trapezoidal profile at the speed and acceleration caps needs, so the leading
joint never exceeds the cap; ``fine`` makes each an exact stop, ``WaitTime
\\InPos`` dwells once the arm is in position, and ``PulseDO`` pulses a signal
(``do_calibrator`` by default: create it in the I/O configuration, or edit
the name). A via (moved through, not measured) is a ``MoveAbsJ`` after a
``! via before pose i`` comment, with no wait. Every move names ``tool0`` (the
flange with an all-zero tool): the tool ``calibrator compensate
--joint-targets correct`` corrects with.
"""

from __future__ import annotations

import numpy as np

from calibrator.errors import CalibrationError
from calibrator.languages import configuration
from calibrator.languages.names import program_name, taken, words
from calibrator.languages.path_program import PathSpec
from calibrator.languages.registry import writer
from calibrator.languages.spec import PULSE_S, ProgramSpec, move_duration_s, number
from calibrator.languages.statements import between_homes, title
from calibrator.model import rotations

#: Name of the digital output pulsed at each arrival.
SIGNAL = "do_calibrator"
#: Speed of the first move to home, from an unknown start (100 mm/s of the TCP).
FIRST_SPEED = "v100"


#: RAPID's reserved words and the names this module uses (RAPID is case-insensitive).
RESERVED = words(
    "ALIAS AND BACKWARD CASE CONNECT CONST DEFAULT DIV DO ELSE ELSEIF ENDFOR ENDFUNC ENDIF "
    "ENDMODULE ENDPROC ENDRECORD ENDTEST ENDTRAP ENDWHILE ERROR EXIT FALSE FOR FROM FUNC "
    "GOTO IF INOUT LOCAL MOD MODULE NOSTEPIN NOT NOVIEW OR PERS PROC RAISE READONLY RECORD "
    "RETRY RETURN STEP SYSMODULE TEST THEN TO TRAP TRUE TRYNEXT UNDO VAR VIEWONLY WHILE "
    "WITH XOR MAIN JHOME MOVEABSJ WAITTIME PULSEDO TOOL0 FINE V100 JOINTTARGET JSTART VPATH "
    "MOVEL MOVEC CONFL SPEEDDATA Z1 " + SIGNAL.upper()
)
#: Longest RAPID identifier.
MAX_NAME = 32


def _module(name: str) -> str:
    """The module name: the program name's words capitalised (``cal_run`` -> ``CalRun``)."""
    return "".join(w.capitalize() for w in name.split("_")) or "CalibratorMeasure"


def _name(stem: str) -> str:
    name = program_name(
        stem, language="RAPID", reserved=frozenset(), max_length=MAX_NAME, same_as_file=False
    )
    # The module is named from it: that is the name that must not clash.
    if taken(_module(name), RESERVED):
        name = f"{name}_program"
    if len(_module(name)) > MAX_NAME:
        raise CalibrationError(
            f"{stem!r}: a RAPID module name has at most {MAX_NAME} characters: "
            "choose a shorter file name"
        )
    return name


def _target(spec: ProgramSpec, q_rad) -> str:
    robax = ",".join(spec.angles(q_rad, "deg"))
    return f"[[{robax}],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _time(seconds: float) -> str:
    # Rounded up to 10 ms so the move is never faster than the caps allow.
    return f"{max(np.ceil(seconds * 100.0) / 100.0, 0.1):.2f}"


@writer(
    "rapid",
    (".mod",),
    "ABB RAPID for IRC5 (RobotWare 6) and OmniCore (RobotWare 7); deg",
    _name,
)
def write(spec: ProgramSpec) -> str:
    module = _module(spec.name)
    lines = [
        f"MODULE {module}",
        f"  ! {title(spec)}",
        "  ! joints in deg; each move timed (\\T) to keep the leading joint under "
        f"{spec.speed_rad_s:g} rad/s",
        f"  CONST jointtarget jHome := {_target(spec, spec.home_rad)};",
        "  PROC main()",
    ]

    def timed(start: np.ndarray, end: np.ndarray) -> str:
        """The move's speed argument, time-programmed to keep within the caps."""
        seconds = move_duration_s(start, end, spec.speed_rad_s, spec.accel_rad_s2)
        return f"v100 \\T:={_time(seconds)}"

    # From wherever the arm stands: no timed move from an unknown start, a slow one.
    lines.append(f"    MoveAbsJ jHome, {FIRST_SPEED}, fine, tool0;")
    lines += between_homes(
        spec,
        move=lambda kind, pose, start, q: (
            f"    MoveAbsJ {_target(spec, q)}, {timed(start, q)}, fine, tool0;"
        ),
        pulse=lambda output: [f"    PulseDO \\PLength:={PULSE_S:.2f}, {SIGNAL};"],
        dwell=lambda wait: f"    WaitTime \\InPos, {wait:.3f};",
        comment=lambda text: f"    ! {text}",
    )
    _, _, start, end = spec.moves()[-1]
    lines.append(f"    MoveAbsJ jHome, {timed(start, end)}, fine, tool0;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)


#: The path's speeddata and the zone of a blended move (a circle's two arcs meet tangentially).
PATH_SPEED = "vPath"
BLEND_ZONE = "z1"


def _robtarget(spec: PathSpec, k: int) -> str:
    """Target ``k`` as a robtarget literal: mm, quaternion [w, x, y, z], confdata, no ext. axes."""
    pos = ",".join(f"{round(float(v), 6) + 0.0:.6f}" for v in spec.position(k))
    identity = np.array([[1.0, 0.0, 0.0, 0.0]])
    quat = rotations.matrix_to_quaternion(spec.rotation(k)[None], identity)[0]
    orient = ",".join(f"{round(float(v), 9) + 0.0:.9f}" for v in quat)
    # cf1, cf4, cf6: quadrants of the controller's axes 1, 4, 6; cfx: back, elbow down, flip.
    ctrl = np.degrees(
        spec.joints.convention.to_controller(spec.q_rad[k])
        if spec.joints.convention is not None
        else spec.q_rad[k]
    )
    quadrants = configuration.quadrant(ctrl[[0, 3, 5]])
    bits = configuration.arm_bits(spec.mdh, spec.q_rad[k][None])[0]
    cfx = 4 * bits[0] + 2 * bits[1] + bits[2]
    conf = ",".join(str(int(v)) for v in (*quadrants, cfx))
    return f"[[{pos}],[{orient}],[{conf}],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def write_path(spec: PathSpec) -> str:
    """The path program in RAPID: ``MoveAbsJ`` to the start, ``MoveL`` and ``MoveC``.

    The path speed is a ``speeddata`` (``v_tcp`` the stated mm/s); ``MoveC
    CirPoint, ToPoint`` moves through the circle point to the end point.
    Every target names ``tool0`` and ``wobj0`` (the flange in the base
    frame); ``ConfL \\Off`` lets the linear and circular moves keep the
    configuration the joint move to the start chose (each robtarget states it
    too). A blended move ends in zone ``z1``; the others ``fine``.
    """
    module = _module(spec.name)
    joints = spec.joints
    lines = [
        f"MODULE {module}",
        f"  ! ISO 9283 {spec.shape} path, {spec.cycles} cycles at {spec.speed_mm_s:g} mm/s"
        + (f" for {joints.model}" if joints.model else ""),
        "  ! targets: the flange (tool0) in the base frame (wobj0), mm and [w, x, y, z]",
        f"  CONST jointtarget jStart := {_target(joints, joints.home_rad)};",
        # v_tcp mm/s, v_ori deg/s, v_leax mm/s, v_reax deg/s: the orientation is constant.
        f"  CONST speeddata {PATH_SPEED} := [{number(spec.speed_mm_s)},500,5000,1000];",
        "  PROC main()",
        "    ConfL \\Off;",
        f"    MoveAbsJ jStart, {FIRST_SPEED}, fine, tool0;",
    ]
    for _step, move in spec.steps():
        if move is None:
            lines.append(f"    WaitTime \\InPos, {spec.hold_s:.3f};")
            continue
        zone = BLEND_ZONE if move.blend else "fine"
        if move.kind == "line":
            target = _robtarget(spec, move.end)
            lines.append(f"    MoveL {target}, {PATH_SPEED}, {zone}, tool0;")
        else:
            assert move.via is not None
            via, end = _robtarget(spec, move.via), _robtarget(spec, move.end)
            lines.append(f"    MoveC {via}, {end}, {PATH_SPEED}, {zone}, tool0;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)
