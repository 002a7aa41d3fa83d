"""The shipped arms' poses in their vendors' own frames, from an independent reading of the URDFs.

The pendant of each arm shows the pose of its flange (tool 0) in its base
(world) frame. ROS-Industrial's support packages carry both as links,
``base`` and ``tool0`` (the REP-199 draft), so yourdfpy's reading of the
shipped URDF gives the pose a controller would record for joint angles, without
the description's new frames. Where the model's MDH frames sit relative to
them is the description's ``base_offset``/``flange_offset`` (checked against
yourdfpy by ``tests/robots/test_shipped_arms.py``) composed with yourdfpy's
``base_link -> base`` and ``tip -> tool0``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yourdfpy

from calibrator import robots
from calibrator.model import frames, inverse, kinematics, rotations

DATA = Path(robots.__file__).with_name("data")
#: The chain's tip link of each shipped description (typed here, not read from it).
TIPS = {
    "kuka-kr6-r900": "flange",
    "abb-irb4600-60-205": "flange",
    "fanuc-m20ia": "flange",
    "yaskawa-gp8": "tool0",
    "staubli-tx2-60": "flange",
}
#: A user frame (KUKA base, RAPID uframe, Fanuc UF, Yaskawa USER) in the controller's
#: base frame, a RAPID object frame in it, and a tool on the controller's flange (mm, deg).
USER = frames.transform(rotations.zyx_to_matrix([[30.0, 5.0, -3.0]])[0], [300.0, -200.0, 150.0])
OBJECT = frames.transform(rotations.zyx_to_matrix([[-15.0, 0.0, 2.0]])[0], [50.0, 100.0, 20.0])
TOOL = frames.transform(rotations.zyx_to_matrix([[0.0, 30.0, 0.0]])[0], [12.5, -4.0, 180.0])
#: Controller joint boxes (deg) in front of each arm, clear of its singularities.
BOXES = {
    "kuka-kr6-r900": [(-50, 50), (-80, -45), (75, 110), (-60, 60), (35, 80), (-90, 90)],
    "abb-irb4600-60-205": [(-50, 50), (5, 40), (-35, 0), (-60, 60), (35, 80), (-90, 90)],
    "fanuc-m20ia": [(-50, 50), (5, 40), (-35, 0), (-60, 60), (35, 80), (-90, 90)],
    "yaskawa-gp8": [(-50, 50), (5, 40), (-35, 0), (-60, 60), (35, 80), (-90, 90)],
    "staubli-tx2-60": [(-50, 50), (-10, 30), (70, 110), (-60, 60), (35, 80), (-90, 90)],
}


def urdf_angles(name: str, q_ctrl: np.ndarray) -> np.ndarray:
    """The URDF's joint angles of controller angles (rad): FANUC's J3 is J3 + J2."""
    q = np.array(q_ctrl, dtype=float)
    if name == "fanuc-m20ia":
        q[:, 2] = q_ctrl[:, 2] + q_ctrl[:, 1]
    return q


def urdf_transform(name: str, q_urdf: np.ndarray, frame: str, in_frame: str) -> np.ndarray:
    """``frame`` in ``in_frame`` by yourdfpy, mm, one (4, 4) per row of ``q_urdf`` (N, 6)."""
    model = yourdfpy.URDF.load(
        str(DATA / f"{name}.urdf"), load_meshes=False, build_collision_scene_graph=False
    )
    out = []
    for q in np.atleast_2d(q_urdf):
        model.update_cfg(dict(zip(model.actuated_joint_names, q, strict=True)))
        t = np.array(model.get_transform(frame, in_frame))
        t[:3, 3] *= 1000.0
        out.append(t)
    return np.array(out)


def pendant_poses(name: str, q_ctrl: np.ndarray) -> np.ndarray:
    """tool0 in base (mm): what the pendant shows at controller angles ``q_ctrl`` (rad)."""
    return urdf_transform(name, urdf_angles(name, q_ctrl), "tool0", "base")


def model_frames(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(MDH frame 0 in the controller's base, tool0 on the MDH flange), mm, from yourdfpy.

    Checked: the nominal model through them is yourdfpy's base -> tool0.
    """
    arm = robots.get(name)
    zero = np.zeros((1, 6))
    base_link2base = urdf_transform(name, zero, "base", "base_link")[0]
    tip2tool0 = urdf_transform(name, zero, "tool0", TIPS[name])[0]
    base2frame0 = frames.invert(base_link2base) @ arm.base_offset
    flange2tool0 = arm.flange_offset @ tip2tool0
    rng = np.random.default_rng(1)
    q = arm.convention.to_controller(
        rng.uniform(arm.joint_limits_rad[:, 0], arm.joint_limits_rad[:, 1], (5, 6))
    )
    model = base2frame0 @ kinematics.chain(arm.mdh, arm.convention.to_model(q)) @ flange2tool0
    assert np.abs(model - pendant_poses(name, q)).max() < 1e-9
    return base2frame0, flange2tool0


def joints(name: str, n: int, seed: int) -> np.ndarray:
    """Controller joints (rad), (n + 5, 6): ``n`` in the box, then the special cases.

    A flipped wrist (joint 5 negative), joint 1 in other quadrants (+-100 deg),
    joint 6 at +200 deg and the same pose at -160 deg (another turn: KUKA's
    T, RAPID's cf6, Fanuc's t6, Yaskawa's T >= 180 flag differ).
    """
    rng = np.random.default_rng(seed)
    box = np.radians(BOXES[name])
    q = rng.uniform(box[:, 0], box[:, 1], (n, 6))
    special = np.tile(q[0], (5, 1))
    special[0, 4] = -np.radians(50.0)
    special[1, 0] = np.radians(100.0)
    special[2, 0] = np.radians(-100.0)
    special[3, 5] = np.radians(200.0)
    special[4, 5] = np.radians(-160.0)
    return np.concatenate([q, special])


def landed(cal, base2frame0, flange2tool0, sent, user, tool, q_ctrl) -> np.ndarray:
    """Where the true arm puts the tool when the nominal controller is sent ``sent``.

    ``sent`` (N, 4, 4) are poses in the user frames ``user`` (N, 4, 4) for the
    tools ``tool`` (N, 4, 4); the controller solves its nominal model in the
    configuration of ``q_ctrl`` (started there), the true arm turns to those
    joints. Returns the tool poses in the controller's base frame (mm).
    """
    arm = robots.get(cal.model)
    start = arm.convention.to_model(q_ctrl)
    to_model = frames.invert(base2frame0)
    sol = inverse.solve(cal.nominal_mdh, to_model @ user @ sent, start, flange2tool0 @ tool)
    assert sol.converged.all()
    # In the stated configuration: the joints the target was taught at, give or take
    # the calibration's error (a whole turn or another solution would be far).
    assert np.degrees(np.abs(sol.q - start)).max() < 5.0
    return base2frame0 @ kinematics.chain(cal.mdh, sol.q) @ flange2tool0 @ tool
