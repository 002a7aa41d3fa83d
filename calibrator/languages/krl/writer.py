"""KRL (KUKA KR C4 / KSS 8.x controllers): degrees, ``PTP`` to ``E6AXIS`` aggregates.

Copy the ``.src`` file to the controller (``KRC:\\R1\\Program``); the program
is one ``DEF``. Axis speed is ``$VEL_AXIS[i]``, a percentage of each axis's
top speed (computed from the model's rated joint speeds so the leading joint
never exceeds the cap), acceleration ``$ACC_AXIS[i]`` in percent. Motions are
exact stops (no ``C_PTP``); ``WAIT SEC`` dwells and ``PULSE($OUT[n], TRUE, t)``
pulses an output. A via (moved through, not measured) is a ``PTP`` after a
``; via before pose i`` comment, with no wait. The program sets ``$TOOL =
$NULLFRAME`` and ``$BASE = $NULLFRAME`` (the flange and the robot base): the
frames ``calibrator compensate --joint-targets correct`` then corrects in.
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

#: KRL keywords, data types and the names this program uses (KRL is case-insensitive).
RESERVED = words(
    "AND ANIN ANOUT AXIS B_AND B_EXOR B_NOT B_OR BOOL BRAKE C_DIS C_ORI C_PTP C_VEL CASE "
    "CHAR CIRC CIRC_REL CONST CONTINUE DECL DEF DEFAULT DEFDAT DEFFCT DELAY DISTANCE DIV DO "
    "E6AXIS E6POS ELSE END ENDDAT ENDFCT ENDFOR ENDIF ENDLOOP ENDSWITCH ENDWHILE ENUM EXIT "
    "EXOR EXT EXTFCT FALSE FOR FRAME GLOBAL GOTO HALT IF IMPORT INT INTERRUPT IS LIN "
    "LIN_REL LOOP MAXIMUM MINIMUM NOT OR POS PRIO PTP PTP_REL PUBLIC PULSE REAL REPEAT "
    "RESUME RETURN SCIRC SEC SIGNAL SLIN SPL SPLINE SPTP STEP STRUC SWITCH THEN TO TRIGGER "
    "TRUE UNTIL WAIT WHEN WHILE HOME_POS START_POS"
)
#: Longest KRL name.
MAX_NAME = 24


def _name(stem: str) -> str:
    # KSS loads a module only when its DEF is named as its file.
    return program_name(
        stem, language="KRL", reserved=RESERVED, max_length=MAX_NAME, same_as_file=True
    ).upper()


#: Axis acceleration as a percentage of the machine data's maximum (gentle: a calibration
#: program needs settled stops, not short cycle times).
ACC_PERCENT = 20


def _axis(spec: ProgramSpec, q_rad) -> str:
    deg = spec.angles(q_rad, "deg")
    return "{" + ", ".join(f"A{i + 1} {v}" for i, v in enumerate(deg)) + "}"


@writer("krl", (".src",), "KUKA KRL for KR C4 (KSS 8.x); deg", _name)
def write(spec: ProgramSpec) -> str:
    if spec.pulse_output is not None and spec.pulse_output < 1:
        raise CalibrationError("KRL $OUT outputs are numbered from 1, not 0")
    name = spec.name.upper()
    lines = [
        f"DEF {name}()",
        f"; {title(spec)}",
        "; joints in deg; axis speeds in percent of each axis's top speed",
        "DECL E6AXIS HOME_POS",
        f"HOME_POS = {_axis(spec, spec.home_rad)}",
    ]
    for axis, pct in enumerate(spec.speed_percent(0.1, "KRL"), start=1):
        lines.append(f"$VEL_AXIS[{axis}] = {pct:.1f}")
    for axis in range(1, 7):
        lines.append(f"$ACC_AXIS[{axis}] = {ACC_PERCENT}")
    # The frames the program assumes: the flange and $ROBROOT. Joint moves do not
    # depend on them, but `compensate --joint-targets correct` corrects in them.
    lines += ["$TOOL = $NULLFRAME", "$BASE = $NULLFRAME"]
    lines.append("PTP HOME_POS")
    lines += between_homes(
        spec,
        move=lambda kind, pose, start, q: f"PTP {_axis(spec, q)}",
        pulse=lambda output: [f"PULSE($OUT[{output}], TRUE, {PULSE_S:.2f})"],
        dwell=lambda wait: f"WAIT SEC {wait:.3f}",
        comment=lambda text: f"; {text}",
    )
    lines += ["PTP HOME_POS", "END", ""]
    return "\n".join(lines)


#: Approximation distance of a blended move (a circle's two arcs meet tangentially), mm.
BLEND_MM = 1.0


def _frame(spec: PathSpec, k: int) -> str:
    """Target ``k`` as a KRL ``FRAME`` aggregate: mm and ZYX angles A, B, C in deg."""
    x, y, z = spec.position(k)
    a, b, c = rotations.matrix_to_zyx(spec.rotation(k)[None], np.zeros(3))[0]
    values = zip("XYZABC", (x, y, z, a, b, c), strict=True)
    # 1e-6 mm and deg: far below any controller's resolution; + 0.0 turns -0.0 into 0.0.
    return "{" + ", ".join(f"{n} {round(float(v), 6) + 0.0:.6f}" for n, v in values) + "}"


def write_path(spec: PathSpec) -> str:
    """The path program in KRL: ``PTP`` to the start, ``LIN`` and ``CIRC`` at ``$VEL.CP``.

    ``$VEL.CP`` is the path speed in m/s and ``$ACC.CP`` its acceleration in
    m/s^2; ``$ORI_TYPE = #CONSTANT`` keeps the orientation of the start (the
    same at every target; ``#VAR`` for compensated targets, whose orientations
    differ by the correction), ``$CIRC_TYPE = #BASE`` guides it in the base.
    ``CIRC aux, end`` moves through the auxiliary point to the end point; a
    blended move ends ``C_DIS`` (``$APO.CDIS`` mm), the others stop exactly.
    """
    name = spec.name.upper()
    joints = spec.joints
    lines = [
        f"DEF {name}()",
        f"; ISO 9283 {spec.shape} path, {spec.cycles} cycles at {spec.speed_mm_s:g} mm/s"
        + (f" for {joints.model}" if joints.model else ""),
        "; joints in deg; targets: the flange ($TOOL = $NULLFRAME) in $ROBROOT "
        "($BASE = $NULLFRAME), mm, and A, B, C (about Z, Y, X) in deg",
        "DECL E6AXIS START_POS",
        f"START_POS = {_axis(joints, joints.home_rad)}",
    ]
    for axis, pct in enumerate(joints.speed_percent(0.1, "KRL"), start=1):
        lines.append(f"$VEL_AXIS[{axis}] = {pct:.1f}")
    for axis in range(1, 7):
        lines.append(f"$ACC_AXIS[{axis}] = {ACC_PERCENT}")
    lines += [
        "$TOOL = $NULLFRAME",
        "$BASE = $NULLFRAME",
        f"$VEL.CP = {number(spec.speed_mm_s / 1000.0)}",
        f"$ACC.CP = {number(spec.accel_mm_s2 / 1000.0)}",
        # Compensated targets differ in orientation by the correction: turned to along each move.
        f"$ORI_TYPE = {'#VAR' if spec.compensated else '#CONSTANT'}",
        "$CIRC_TYPE = #BASE",
        f"$APO.CDIS = {BLEND_MM:g}",
        "PTP START_POS",
    ]
    for _step, move in spec.steps():
        if move is None:
            lines.append(f"WAIT SEC {spec.hold_s:.3f}")
            continue
        blend = " C_DIS" if move.blend else ""
        if move.kind == "line":
            lines.append(f"LIN {_frame(spec, move.end)}{blend}")
        else:
            assert move.via is not None
            lines.append(f"CIRC {_frame(spec, move.via)}, {_frame(spec, move.end)}{blend}")
    lines += ["END", ""]
    return "\n".join(lines)
