"""KRL (KUKA KR C4 / KSS 8.x controllers): degrees, ``PTP`` to ``E6AXIS`` aggregates.

Copy the ``.src`` file to the controller (``KRC:\\R1\\Program``); the program
is one ``DEF``. Axis speed is ``$VEL_AXIS[i]``, a percentage of each axis's
top speed (computed from the model's rated joint speeds so the leading joint
never exceeds the cap), acceleration ``$ACC_AXIS[i]`` in percent. Motions are
exact stops (no ``C_PTP``); ``WAIT SEC`` dwells and ``PULSE($OUT[n], TRUE, t)``
pulses an output. A via (moved through, not measured) is a ``PTP`` after a
``; via before pose i`` comment, with no wait.
"""

from __future__ import annotations

from calibrator.program import ProgramSpec, between_homes, degrees, title, writer
from calibrator.program.spec import DEG_DECIMALS, PULSE_S

#: Axis acceleration as a percentage of the machine data's maximum (gentle: a calibration
#: program needs settled stops, not short cycle times).
ACC_PERCENT = 20


def _axis(q_rad) -> str:
    deg = degrees(q_rad)
    return "{" + ", ".join(f"A{i + 1} {v:.{DEG_DECIMALS}f}" for i, v in enumerate(deg)) + "}"


@writer("krl", (".src",), "KUKA KRL for KR C4 (KSS 8.x); deg")
def write(spec: ProgramSpec) -> str:
    name = spec.name.upper()[:24]  # KRL names: at most 24 characters
    lines = [
        f"DEF {name}()",
        f"; {title(spec)}",
        "; joints in deg; axis speeds in percent of each axis's top speed",
        "DECL E6AXIS HOME_POS",
        f"HOME_POS = {_axis(spec.home_rad)}",
    ]
    for axis, pct in enumerate(spec.speed_percent(), start=1):
        lines.append(f"$VEL_AXIS[{axis}] = {pct:.1f}")
    for axis in range(1, 7):
        lines.append(f"$ACC_AXIS[{axis}] = {ACC_PERCENT}")
    lines.append("PTP HOME_POS")
    lines += between_homes(
        spec,
        move=lambda kind, pose, start, q: f"PTP {_axis(q)}",
        pulse=lambda output: [f"PULSE($OUT[{output}], TRUE, {PULSE_S:.2f})"],
        dwell=lambda wait: f"WAIT SEC {wait:.3f}",
        comment=lambda text: f"; {text}",
    )
    lines += ["PTP HOME_POS", "END", ""]
    return "\n".join(lines)
