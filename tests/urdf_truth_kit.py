"""A hidden true arm from a URDF: its joint origins moved and turned (not a test module)."""

import xml.etree.ElementTree as ET

import numpy as np


def perturbed(text: str, rng: np.random.Generator, turn_deg: tuple = (0.01, 0.1)) -> str:
    """``text`` with every joint origin moved 0.1-1 mm and turned ``turn_deg`` per axis.

    A turn about a joint's own axis moves its zero, so the true arm's joint
    zeros are off too.
    """
    root = ET.fromstring(text)
    for joint in root.findall("joint"):
        origin = joint.find("origin")
        if origin is None:
            origin = ET.SubElement(joint, "origin")
        signs = rng.choice([-1.0, 1.0], (2, 3))
        xyz = np.array((origin.get("xyz") or "0 0 0").split(), float)
        rpy = np.array((origin.get("rpy") or "0 0 0").split(), float)
        xyz += signs[0] * rng.uniform(0.1e-3, 1e-3, 3)
        rpy += signs[1] * np.radians(rng.uniform(*turn_deg, 3))
        origin.set("xyz", " ".join(repr(float(v)) for v in xyz))
        origin.set("rpy", " ".join(repr(float(v)) for v in rpy))
    return ET.tostring(root, encoding="unicode")
