"""A robot description of a URDF's chain: kinematics, limits, masses, body, frames."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibrator.model import kinematics
from calibrator.robots.description import (
    JointConvention,
    RobotDescription,
)
from calibrator.robots.urdf.body import FIT_MARGIN_MM, fit_body
from calibrator.robots.urdf.chain import (
    read_chain,
)
from calibrator.robots.urdf.frames import controller_frames
from calibrator.robots.urdf.kinematics import kinematics_of, upright
from calibrator.robots.urdf.limits import joint_limits
from calibrator.robots.urdf.masses import masses_of
from calibrator.robots.urdf.sweeps import narrow_limits


def describe(
    path: str | Path,
    base_link: str | None = None,
    tip_link: str | None = None,
    name: str | None = None,
    margin_mm: float = FIT_MARGIN_MM,
    link_radius_mm: np.ndarray | None = None,
) -> RobotDescription:
    """A robot description of the chain of a URDF file.

    Parameters
    ----------
    path : str or Path
    base_link, tip_link : str, optional
        See :func:`read_chain`.
    name : str, optional
        The description's name [default: the path as given].
    margin_mm, link_radius_mm
        See :func:`fit_body`.

    Raises
    ------
    DescriptionError
        One line naming what is wrong or unsupported.
    """
    chain = read_chain(path, base_link, tip_link)
    kin = kinematics_of(chain)
    limits, speeds = joint_limits(chain, kin.sign)
    # Base link -> MDH frame i at the zero pose.
    model_frames = kin.base_offset @ kinematics.chain(kin.mdh, np.zeros(6), all_frames=True)[1][0]
    masses = masses_of(chain, model_frames)
    body = fit_body(chain, model_frames, margin_mm, link_radius_mm)
    limits, notes = narrow_limits(chain, body, model_frames, limits, kin.sign, margin_mm)
    base2world, flange2tool0, sources = controller_frames(chain)
    return RobotDescription(
        name=name or str(path),
        mdh=kin.mdh,
        joint_limits_rad=limits,
        max_joint_speed_rad_s=speeds,
        body=body,
        configurations={
            "home": (0.0,) * 6,
            "upright": upright(kin.mdh, limits, kin.base_offset),
        },
        mass_kg=None if masses is None else masses[0],
        com_mm=None if masses is None else masses[1],
        convention=JointConvention(
            sign=tuple(float(s) for s in kin.sign),
            source="the URDF's joint angles (ROS-Industrial drivers pass the controller's through)",
        ),
        base_offset=kin.base_offset,
        flange_offset=kin.flange_offset,
        source=f"URDF {Path(path).name} ({chain.robot}), {chain.base_link} to {chain.tip_link}",
        limit_notes=notes,
        base2controller_base=base2world,
        flange2controller_flange=flange2tool0,
        controller_base_source=sources[0],
        controller_flange_source=sources[1],
    )
