"""RAPID (ABB IRC5 with RobotWare 6.x, OmniCore with RobotWare 7.x): degrees, ``MoveAbsJ``.

Load the ``.mod`` module into the task (it holds ``PROC main``). Joint
targets are ``jointtarget`` literals (robot axes in degrees, external axes
``9E9``: none). Each move is time-programmed (``\\T``) to the duration a
trapezoidal profile at the speed and acceleration caps needs, so the leading
joint never exceeds the cap; ``fine`` makes each an exact stop, ``WaitTime
\\InPos`` dwells once the arm is in position, and ``PulseDO`` pulses a signal
(``do_calibrator`` by default: create it in the I/O configuration, or edit
the name). A via (moved through, not measured) is a ``MoveAbsJ`` after a
``! via before pose i`` comment, with no wait.
"""

from __future__ import annotations

import numpy as np

from calibrator.program import ProgramSpec, between_homes, degrees, move_duration_s, title, writer
from calibrator.program.spec import DEG_DECIMALS, PULSE_S

#: Name of the digital output pulsed at each arrival.
SIGNAL = "do_calibrator"
#: Speed of the first move to home, from an unknown start (100 mm/s of the TCP).
FIRST_SPEED = "v100"


def _target(q_rad) -> str:
    robax = ",".join(f"{v:.{DEG_DECIMALS}f}" for v in degrees(q_rad))
    return f"[[{robax}],[9E9,9E9,9E9,9E9,9E9,9E9]]"


def _time(seconds: float) -> str:
    # Rounded up to 10 ms so the move is never faster than the caps allow.
    return f"{max(np.ceil(seconds * 100.0) / 100.0, 0.1):.2f}"


@writer("rapid", (".mod",), "ABB RAPID for IRC5 (RobotWare 6) and OmniCore (RobotWare 7); deg")
def write(spec: ProgramSpec) -> str:
    module = "".join(w.capitalize() for w in spec.name.split("_")) or "CalibratorMeasure"
    lines = [
        f"MODULE {module}",
        f"  ! {title(spec)}",
        "  ! joints in deg; each move timed (\\T) to keep the leading joint under "
        f"{spec.speed_rad_s:g} rad/s",
        f"  CONST jointtarget jHome := {_target(spec.home_rad)};",
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
            f"    MoveAbsJ {_target(q)}, {timed(start, q)}, fine, tool0;"
        ),
        pulse=lambda output: [f"    PulseDO \\PLength:={PULSE_S:.2f}, {SIGNAL};"],
        dwell=lambda wait: f"    WaitTime \\InPos, {wait:.3f};",
        comment=lambda text: f"    ! {text}",
    )
    _, _, start, end = spec.moves()[-1]
    lines.append(f"    MoveAbsJ jHome, {timed(start, end)}, fine, tool0;")
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)
