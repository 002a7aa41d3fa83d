"""Simulated arms with joint errors: what the robot reads is not what the joint turns to."""

import numpy as np

from calibrator import robots, session, simulate
from calibrator.identify import pipeline
from calibrator.model import frames, joint_terms, kinematics, rotations
from calibrator.robots import masses as robot_masses


def sessions(
    terms,
    poses=60,
    seed=5,
    payloads_kg=(0.0,),
    noise_mm=0.02,
    orientation_noise_rad=2e-5,
    model="ur10e",
    geometry_errors=True,
    narrow_first=None,
):
    """One simulated 6-DoF session (base frame) per payload, and the truth.

    ``terms`` is a :class:`calibrator.model.joint_terms.JointTerms` applied to the
    read-back angles: ``q_true = q_eff(q_read)``; the gravity torques come from
    the model's published mass model and each session's payload (a point mass
    100 mm out on the flange axis, the probe's side). ``narrow_first=(n, f)``
    draws the first ``n`` poses of each session from ``f`` times the joint ranges,
    so that the others lie partly outside the range of the first.

    Returns
    -------
    list of (Session, torque (N, 6), payload_kg)
    truth : dict with ``mdh``, ``tool``
    """
    rng = np.random.default_rng(seed)
    robot = robots.get(model)
    masses = robot_masses.get(model)
    delta = simulate.random_errors(robot.mdh, rng, mm=0.3, rad=0.003)
    delta[:, kinematics.BETA] = 0.0
    true_mdh = robot.mdh + (delta if geometry_errors else 0.0)
    tool = frames.transform(translation=[30.0, -20.0, 100.0])
    out = []
    for payload in payloads_kg:
        limits = np.clip(robot.joint_limits_rad, -np.pi, np.pi)
        q = simulate.sample_joints(limits, poses, rng)
        if narrow_first is not None:
            q[: narrow_first[0]] *= narrow_first[1]
        tau = joint_terms.gravity_torques(robot.mdh, q, masses, payload, [0.0, 0.0, 100.0])
        q_true = joint_terms.effective(q, terms.vector(), tau)
        pose = kinematics.forward(true_mdh, q_true, tool)
        points = pose[:, :3, 3] + rng.normal(0.0, noise_mm / np.sqrt(3), (poses, 3))
        tilt = rng.normal(0.0, orientation_noise_rad / np.sqrt(3), (poses, 3))
        rot = rotations.rotvec_to_matrix(tilt) @ pose[:, :3, :3]
        table = session.to_table(q, points, rotvecs=rotations.matrix_to_rotvec(rot))
        meta = session.SessionMeta(
            frame="base", nominal_mdh=robot.mdh, model=robot.name, flange2tool=tool,
            tool_known=True, extra={"payload_kg": payload},
        )  # fmt: skip
        out.append((session.Session(table, meta), tau, payload))
    return out, {"mdh": true_mdh, "tool": tool}


def merged(parts):
    """One in-memory session of several (same arm), with torques and payloads per pose."""
    import pyarrow as pa

    table = pa.concat_tables([s.table for s, _, _ in parts])
    n = table.num_rows
    table = table.set_column(table.column_names.index("pose"), "pose", pa.array(np.arange(n)))
    torque = np.concatenate([t for _, t, _ in parts])
    payload = np.concatenate([np.full(len(t), p) for _, t, p in parts])
    return session.Session(table, parts[0][0].meta), torque, payload


def geometric_fit(sess, validation_fraction=0.0, noise_mm=0.02):
    """The pipeline's geometric least-squares fit (no swarm: the start is close)."""
    options = pipeline.Options(
        method="lm", validation_fraction=validation_fraction, noise_mm=noise_mm
    )
    return pipeline.identify(sess, options)
