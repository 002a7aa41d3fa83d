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

from calibrator.errors import CalibrationError
from calibrator.languages.names import program_name, words
from calibrator.languages.registry import writer
from calibrator.languages.spec import PULSE_S, ProgramSpec
from calibrator.languages.statements import between_homes, title

#: KRL keywords, data types and the names this program uses (KRL is case-insensitive).
RESERVED = words(
    "AND ANIN ANOUT AXIS B_AND B_EXOR B_NOT B_OR BOOL BRAKE C_DIS C_ORI C_PTP C_VEL CASE "
    "CHAR CIRC CIRC_REL CONST CONTINUE DECL DEF DEFAULT DEFDAT DEFFCT DELAY DISTANCE DIV DO "
    "E6AXIS E6POS ELSE END ENDDAT ENDFCT ENDFOR ENDIF ENDLOOP ENDSWITCH ENDWHILE ENUM EXIT "
    "EXOR EXT EXTFCT FALSE FOR FRAME GLOBAL GOTO HALT IF IMPORT INT INTERRUPT IS LIN "
    "LIN_REL LOOP MAXIMUM MINIMUM NOT OR POS PRIO PTP PTP_REL PUBLIC PULSE REAL REPEAT "
    "RESUME RETURN SCIRC SEC SIGNAL SLIN SPL SPLINE SPTP STEP STRUC SWITCH THEN TO TRIGGER "
    "TRUE UNTIL WAIT WHEN WHILE HOME_POS"
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
