"""A URDF arm with STL collision meshes for the tests, and an independent look at them.

The arm is the KUKA URDF of :mod:`robot_files_kit` with a box-shaped housing
per link written as STL into a ROS package layout in a test's folder. The
meshes are posed along a plan by yourdfpy, another URDF reader than ours.
"""

import numpy as np
import trimesh
from cli_process_kit import run_cli
from robot_files_kit import KUKA

from calibrator import planning

PACKAGE = "my_arm_support"
#: Each link's next joint (the KUKA KR 6 URDF's joint origins, m): its housing runs there.
NEXT = {2: (0.455, 0, 0), 3: (0, 0, 0.035), 4: (0.42, 0, 0)}


def box(lo, hi):
    """A box mesh from corner ``lo`` to corner ``hi`` (m)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    return trimesh.creation.box(hi - lo, trimesh.transformations.translation_matrix((lo + hi) / 2))


def housings():
    """A mesh per link of the KUKA URDF, in its link frame (m), and the base's."""
    meshes = {"base_link": box((-0.15, -0.15, 0.0), (0.15, 0.15, 0.3))}
    meshes["link_1"] = box((-0.1, -0.1, -0.05), (0.1, 0.1, 0.05))
    for i in (2, 3, 4):
        end = np.asarray(NEXT[i], float)
        meshes[f"link_{i}"] = box(np.minimum(end, 0) - 0.05, np.maximum(end, 0) + 0.05)
    # The forearm ends at axis 5: reaching 50 mm past it, the flange (70 mm out)
    # ran into it at 12 degrees of joint 5, and reading the URDF narrows joint 5 there.
    meshes["link_4"] = box((-0.05, -0.05, -0.05), (NEXT[4][0], 0.05, 0.05))
    # The wrist ends short of the flange (joint 6's origin): the tool is beyond it.
    meshes["link_5"] = box((-0.05, -0.05, -0.05), (0.06, 0.05, 0.05))
    meshes["link_6"] = box((-0.01, -0.04, -0.04), (0.0, 0.04, 0.04))
    return meshes


def arm_with_meshes(tmp_path, meshes, origin=""):
    """The KUKA URDF with ``meshes`` as STL collision meshes, in a ROS package layout."""
    folder = tmp_path / PACKAGE / "meshes" / "collision"
    folder.mkdir(parents=True, exist_ok=True)
    text = KUKA
    for name, mesh in meshes.items():
        mesh.export(folder / f"{name}.stl")
        body = (
            f'<link name="{name}"><collision>{origin}<geometry><mesh filename='
            f'"package://{PACKAGE}/meshes/collision/{name}.stl"/></geometry></collision></link>'
        )
        assert f'<link name="{name}"/>' in text
        text = text.replace(f'<link name="{name}"/>', body)
    path = tmp_path / PACKAGE / "urdf" / "arm.urdf"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def planned(tmp_path, meshes):
    """``calibrator plan`` of 12 poses for the arm with ``meshes``: its URDF, stderr and plan."""
    path = arm_with_meshes(tmp_path, meshes)
    done = run_cli(
        "plan", "--model", path, "--tracker-at", "2000,-800,600", "--poses", "12",
        "--seed", "2", "-o", "plan.csv", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return path, done.stderr, planning.read_plan(tmp_path / "plan.csv")


def along_moves(path_rad, per_move=8):
    """Joint angles along a plan's path: its first pose, then ``per_move`` steps per move."""
    steps = np.linspace(0.0, 1.0, per_move + 1)[1:]
    return [path_rad[0]] + [
        a + (b - a) * t for a, b in zip(path_rad[:-1], path_rad[1:], strict=True) for t in steps
    ]


def posed_mm(model, points_m):
    """Each link's points (its frame, m) in the base link's frame, mm, at ``model``'s pose."""
    placed = {}
    for name, points in points_m.items():
        at = np.array(model.get_transform(name, "base_link"))
        placed[name] = (points @ at[:3, :3].T + at[:3, 3]) * 1000
    return placed
