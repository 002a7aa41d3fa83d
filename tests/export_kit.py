"""Calibrated arms and UR calibration files for the exporter tests (not a test module)."""

import json

import numpy as np

from calibrator import robots, simulate
from calibrator.calibration import Calibration
from calibrator.model import frames, kinematics, parameters, rotations


def calibrated(model="ur10e", seed=4, trailing=True, mm=0.5, rad=0.002):
    """A named arm with hidden MDH errors (Hayati betas included), a tool and a base.

    With ``trailing`` false, ``a6`` and ``alpha6`` keep their nominal values.
    """
    rng = np.random.default_rng(seed)
    nominal = robots.get(model).mdh
    mdh = nominal + simulate.random_errors(nominal, rng, mm=mm, rad=rad)
    if not trailing:
        mdh[5, [kinematics.A, kinematics.ALPHA]] = nominal[5, [kinematics.A, kinematics.ALPHA]]
    tool = frames.transform(rotations.rotvec_to_matrix([0.1, -0.2, 0.3]), [5.0, -3.0, 120.0])
    base = frames.transform(rotations.rotvec_to_matrix([0.0, 0.0, 1.0]), [2500.0, 100.0, -300.0])
    free = parameters.structural_candidates(nominal, "base", True)[0]
    return Calibration(
        nominal_mdh=nominal,
        mdh=mdh,
        base2tracker=base,
        flange2tool=tool,
        model=model,
        free=free + ["tool_x"],
        # MDH deltas as the table says (frame deltas: relative to identity first guesses).
        deltas=_deltas(nominal, mdh, free + ["tool_x"]),
    )


def _deltas(nominal, mdh, free):
    """``{name: delta}`` of the free parameters as the MDH table gives them."""
    space = parameters.ParameterSpace(nominal, free=tuple(free))
    return dict(zip(space.free, space.pack(mdh), strict=True))


def poses(n=100, seed=1):
    """Joint angles spread over every joint's whole turn, (n, 6) rad."""
    return np.random.default_rng(seed).uniform(-np.pi, np.pi, (n, 6))


def rot(axis, angle):
    """Elementary rotation about ``"x"``, ``"y"`` or ``"z"``, (3, 3), written out."""
    c, s = np.cos(angle), np.sin(angle)
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def urdf_origin(xyz, rpy):
    """A URDF/ROS origin: ``Trans(xyz) . Rz(yaw) Ry(pitch) Rx(roll)``, (4, 4)."""
    t = np.eye(4)
    t[:3, :3] = rot("z", rpy[2]) @ rot("y", rpy[1]) @ rot("x", rpy[0])
    t[:3, 3] = xyz
    return t


#: The delta sections of a UR calibration file.
KEYS = ("delta_theta", "delta_a", "delta_d", "delta_alpha")


def ur_file(tmp_path, values=None, model="ur10", name="cal.conf", drop=()):
    """A UR calibration file written by hand: ``values[key]`` lists (m, rad)."""
    values = values or {k: [0, 0, 0, 0, 0, 0] for k in KEYS}
    lines = ["[mounting]"]
    lines += [f"{k} = {json.dumps(values[k])}" for k in KEYS if k not in drop]
    if model is not None:
        lines += ["", "[calibrator]", f"model = {model}"]
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path
