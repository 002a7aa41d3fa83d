"""URScript (Universal Robots, CB3 3.x and e-Series 5.x controllers): radians, ``movej``.

Load as a script file (``.script``) in a Script node or send it to the
controller's secondary interface; the program is one ``def``, indented by two
spaces, ``movej(q, a, v)`` with joint vectors in radians and the leading-joint
speed and acceleration in rad/s and rad/s^2, ``sleep(t)`` for the dwell and
``set_standard_digital_out(n, b)`` for the pulse. A via (moved through, not
measured) is a ``movej`` after a ``# via before pose i`` comment, with no sleep.
"""

from __future__ import annotations

import numpy as np

from calibrator.program import ProgramSpec, between_homes, title, writer
from calibrator.program.spec import PULSE_S, RAD_DECIMALS


def _joints(q) -> str:
    return "[" + ", ".join(f"{v:.{RAD_DECIMALS}f}" for v in np.asarray(q, float)) + "]"


@writer("urscript", (".script", ".urscript"), "URScript for UR controllers (CB3, e-Series); rad")
def write(spec: ProgramSpec) -> str:
    move = f"a={spec.accel_rad_s2:.4f}, v={spec.speed_rad_s:.4f}"
    lines = [
        f"# {spec.name}: {title(spec)}",
        "# joints in rad; speed and acceleration of the leading joint in rad/s and rad/s^2",
        f"def {spec.name}():",
        f"  home = {_joints(spec.home_rad)}",
        f"  movej(home, {move})",
    ]
    lines += between_homes(
        spec,
        move=lambda kind, pose, start, q: f"  movej({_joints(q)}, {move})",
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
