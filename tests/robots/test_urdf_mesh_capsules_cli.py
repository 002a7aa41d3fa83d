"""Plans for URDF arms with collision meshes, made by the command in new processes.

A plan passes its checks and keeps the meshes (posed by yourdfpy) apart and
above the plane; a turret whose capsule dips below the plane refuses no pose.
The capsules themselves are tested in process in test_urdf_mesh_capsules.py.
"""

import numpy as np
import trimesh
import yourdfpy
from cli_process_kit import run_cli
from scipy.spatial import cKDTree
from urdf_mesh_kit import along_moves, arm_with_meshes, box, housings, planned, posed_mm

from calibrator import cell, planning, robots
from calibrator.model import kinematics
from calibrator.robots import urdf


def test_a_plan_for_a_urdf_arm_with_meshes_passes_its_checks_and_the_meshes(tmp_path):
    meshes = housings()
    path, _, plan = planned(tmp_path, meshes)
    arm = robots.get(str(path))
    checked = planning.check_plan(
        plan, arm, cell.Cell(tracker_at_mm=(2000.0, -800.0, 600.0)), (0, 0, 100)
    )
    assert len(checked.q_rad) == 12
    # Independently: the meshes posed by another URDF reader along every move.
    model = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False)
    chain = urdf.read_chain(path)
    names, links = [j.name for j in chain.moving], [j.child for j in chain.moving]
    surface = {k: trimesh.sample.sample_surface(m, 400, seed=0)[0] for k, m in meshes.items()}
    sign = np.array(arm.convention.sign)
    lowest, closest = np.inf, np.inf
    order = ["base_link", *links]
    for q in along_moves(plan.path_rad):
        model.update_cfg(dict(zip(names, q * sign, strict=True)))
        world = posed_mm(model, {name: surface[name] for name in order})
        lowest = min(lowest, min(world[n][:, 2].min() for n in links[1:]))
        for i in range(len(order)):
            for j in range(i + 2, len(order)):
                closest = min(closest, cKDTree(world[order[i]]).query(world[order[j]])[0].min())
    assert lowest > 0.0
    assert closest > 0.0


def test_a_turret_whose_capsule_dips_below_the_plane_does_not_refuse_every_pose(tmp_path):
    # A flat turret 800 mm square on link 1: its capsule (403 mm round) reaches
    # below the plane the base stands on, at every pose alike (link 1 turns
    # about the plane's normal); an IRB 6640's does by 123 mm, and no pose passed.
    meshes = housings()
    meshes["link_1"] = box((-0.4, -0.4, -0.1), (0.4, 0.4, 0.0))
    path = arm_with_meshes(tmp_path, meshes)
    arm = robots.get(str(path))
    (turret,) = (c for c in arm.body.capsules if c.link == 1)
    frame_1 = kinematics.chain(arm.mdh, np.zeros(6), all_frames=True)[1][0][1]
    lowest = min((frame_1 @ np.append(p, 1.0))[2] for p in (turret.p_mm, turret.q_mm))
    assert lowest - turret.radius_mm < arm.body.mount_z_mm
    done = run_cli(
        "plan", "--model", path, "--tracker-at", "2000,-800,600", "--poses", "12",
        "--seed", "2", "-o", "plan.csv", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    # Links 2 on are still kept off the plane: the stretched-out arm laid down is refused.
    geo = cell.arm_geometry(arm, arm.mdh, (0, 0, 100))
    chk = cell.checker(geo, cell.Cell())
    tilted = np.zeros((2, 6))
    tilted[:, 1] = (np.pi / 2, -np.pi / 2)
    flange_z = kinematics.chain(arm.mdh, tilted)[:, 2, 3]
    down = tilted[np.argsort(flange_z)]  # pointing down, then up
    assert cell.checks.collision_faults(chk, down)[:, 0].tolist() == [True, False]
