"""A description's canonical content (what its digest hashes) holds the whole arm.

Rebuilt from ``as_dict()`` alone, every description is the same arm: the
same digest and the same content. A field left out or written under
another name would let two different arms share a digest (a plan or a
session recorded for one accepted for the other).
"""

from __future__ import annotations

import numpy as np
import pytest
from robot_files_kit import DESCRIPTION
from urdf_mesh_kit import arm_with_meshes, housings

from calibrator import robots
from calibrator.robots import Body, Capsule, JointConvention, RobotDescription, urdf


def _rebuilt(content: dict) -> RobotDescription:
    body = content["body"]
    conv = content["convention"]
    frames = content.get("controller_frames")
    return RobotDescription(
        name=content["name"],
        mdh=content["mdh"],
        joint_limits_rad=content["joint_limits_rad"],
        max_joint_speed_rad_s=content["max_joint_speed_rad_s"],
        family=content["family"],
        body=None
        if body is None
        else Body(
            capsules=tuple(
                Capsule(c["name"], c["link"], tuple(c["p_mm"]), tuple(c["q_mm"]), c["radius_mm"])
                for c in body["capsules"]
            ),
            base_radius_mm=body["base_radius_mm"],
            base_top_mm=body["base_top_mm"],
            mount_z_mm=body["mount_z_mm"],
            shoulder_mm=tuple(body["shoulder_mm"]),
            margin_mm=body["margin_mm"],
            source=body["source"],
        ),
        configurations={k: tuple(v) for k, v in content["configurations"].items()},
        max_joint_accel_rad_s2=content["max_joint_accel_rad_s2"],
        mass_kg=content["mass_kg"],
        com_mm=content["com_mm"],
        convention=JointConvention(
            sign=tuple(conv["sign"]),
            offset_rad=tuple(conv["offset_rad"]),
            couplings=tuple((int(j), int(k), float(f)) for j, k, f in conv["couplings"]),
            source=conv["source"],
        ),
        base_offset=content["base_offset"],
        flange_offset=content["flange_offset"],
        reference_errors=content["reference_errors"],
        source=content["source"],
        limit_notes=tuple(content.get("limit_notes", ())),
        controller_limits_rad=content.get("controller_limits_rad"),
        base2controller_base=np.eye(4) if frames is None else frames["base2controller_base"],
        flange2controller_flange=np.eye(4)
        if frames is None
        else frames["flange2controller_flange"],
        controller_base_source="" if frames is None else frames["base_source"],
        controller_flange_source="" if frames is None else frames["flange_source"],
    )


def _same(arm: RobotDescription) -> None:
    again = _rebuilt(arm.as_dict())
    assert again.as_dict() == arm.as_dict()
    assert again.digest == arm.digest


@pytest.mark.parametrize("name", robots.names())
def test_every_shipped_arm_is_rebuilt_from_its_canonical_content(name):
    _same(robots.get(name))


def test_a_urdf_arm_with_narrowed_limits_keeps_its_notes(tmp_path):
    arm = urdf.describe(arm_with_meshes(tmp_path, housings()))
    assert arm.limit_notes  # joint 5 narrowed by the flange in the forearm
    _same(arm)
    bare = RobotDescription(**{**_fields(arm), "limit_notes": ()})
    assert bare.digest != arm.digest


def test_a_description_file_with_masses_and_frames_is_rebuilt(tmp_path):
    text = DESCRIPTION + (
        "masses:\n  mass_kg: [10, 8, 5, 2, 1, 0.5]\n"
        "  com_mm: [[0, 0, 1], [2, 0, 0], [0, 3, 0], [0, 0, 4], [5, 0, 0], [0, 6, 0]]\n"
        "frames:\n  flange: {xyz_mm: [0, 0, 12], rpy_deg: [0, 0, 90], source: a test}\n"
    )
    (tmp_path / "arm.yaml").write_text(text)
    arm = robots.get(str(tmp_path / "arm.yaml"))
    assert arm.has_masses and arm.has_controller_frames
    _same(arm)


def _fields(arm: RobotDescription) -> dict:
    from dataclasses import fields

    return {f.name: getattr(arm, f.name) for f in fields(arm)}


def test_the_body_capsules_links_and_sources_are_in_the_digest():
    arm = robots.get("kuka-kr6-r900")
    f = _fields(arm)
    first, *rest = arm.body.capsules
    moved = Capsule(first.name, 2, first.p_mm, first.q_mm, first.radius_mm)
    for body in (
        Body(**{**_fields(arm.body), "capsules": (moved, *rest)}),
        Body(**{**_fields(arm.body), "source": "another"}),
    ):
        assert RobotDescription(**{**f, "body": body}).digest != arm.digest
