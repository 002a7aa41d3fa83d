"""Link masses and centres of mass from a URDF's ``<inertial>`` elements."""

from __future__ import annotations

import numpy as np

from calibrator.robots.urdf.chain import (
    Chain,
    fail,
    link_groups,
    numbers,
    origin_of,
)


def masses_of(chain: Chain, model_frames: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    frames = chain.link_frames()
    mass = np.zeros(6)
    com = np.zeros((6, 3))
    for i, names in enumerate(link_groups(chain)[1:]):
        total, moment = 0.0, np.zeros(3)
        for name in names:
            inertial = chain.root.find(f"link[@name='{name}']/inertial")
            if inertial is None or inertial.find("mass") is None:
                continue
            where = f"{chain.path}: link {name!r} inertial"
            m = numbers(inertial.find("mass").get("value"), 1, (0.0,), where)[0]  # type: ignore[union-attr]
            if m < 0:
                raise fail(chain.path, f"link {name!r} has a negative mass")
            point = frames[name] @ origin_of(inertial.find("origin"), where)[:, 3]
            total += m
            moment += m * point[:3]
        if total > 0:
            mass[i] = total
            local = np.linalg.inv(model_frames[i + 1]) @ np.append(moment / total, 1.0)
            com[i] = local[:3]
    return (mass, com) if mass.any() else None
