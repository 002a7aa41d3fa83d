"""URScript (Universal Robots, CB3 3.x and e-Series 5.x controllers): radians, ``movej``.

Load as a script file (``.script``) in a Script node or send it to the
controller's secondary interface; the program is one ``def``, indented by two
spaces, ``movej(q, a, v)`` with joint vectors in radians and the leading-joint
speed and acceleration in rad/s and rad/s^2, ``sleep(t)`` for the dwell and
``set_standard_digital_out(n, b)`` for the pulse. A via (moved through, not
measured) is a ``movej`` after a ``# via before pose i`` comment, with no sleep.
"""

from __future__ import annotations

from calibrator.errors import CalibrationError
from calibrator.program.names import program_name, words
from calibrator.program.registry import writer
from calibrator.program.spec import PULSE_S, ProgramSpec, number
from calibrator.program.statements import between_homes, title

#: URScript's keywords and the names this program uses (case-sensitive).
RESERVED = words(
    "def end if elif else while for in return break continue thread run join kill global "
    "local and or not xor True False pass sec halt enter_critical exit_critical "
    "movej sleep set_standard_digital_out home",
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
        f"def {spec.name}():",
        f"  home = {_joints(spec, spec.home_rad)}",
        f"  movej(home, {move})",
    ]
    lines += between_homes(
        spec,
        move=lambda kind, pose, start, q: f"  movej({_joints(spec, q)}, {move})",
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
