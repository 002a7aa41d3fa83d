"""Robot descriptions from a URDF: the serial chain from a base link to a tip link.

The chain's joint axes at the zero pose are converted exactly to an MDH table
(:func:`calibrator.model.conventions.fit_links`, the conversion the ROS kinematics
import uses), with Hayati's ``beta`` where neighbouring axes are parallel;
what the table cannot hold is kept: ``base_offset`` (MDH frame 0 in the base
link) and ``flange_offset`` (the tip link in the MDH flange frame), so that
for URDF joint angles ``q``::

    base_link2tip(q) = base_offset . A_1...A_6(to_model(q)) . flange_offset

Model angles are the URDF's, except that joint 1 turns about the base's +z
and joint 6 about the axis pointing out of the flange (so the MDH flange
frame's z points where the tool is, as on a UR): where the URDF's axis points
the other way (KUKA's A1, several A6/J6), the model angle is its negative,
recorded as the joint convention's sign. URDF angles are taken to
be the controller's (ROS-Industrial drivers pass them through; where a
controller differs, such as Fanuc's J2/J3 coupling, a description file
declares it).

Also read: position and velocity limits (``<limit>``; continuous joints get
+-2 pi), masses and centres of mass (``<inertial>`` of each moving link and
the links fixed to it), the collision geometry (boxes, cylinders, spheres;
meshes through trimesh when the file can be found) fitted with capsules at a
stated margin. Arms that are not serial 6R chains are refused in one line.

The controller's frames are ROS-Industrial's (the REP-199 draft): a link
``base`` fixed to the chain's base link is the controller's base (world)
frame, a link ``tool0`` fixed to the tip its flange with an all-zero tool
(:func:`controller_frame`). A base link named that is not above the tip but
fixed beside the chain (FANUC's ``base`` hangs off ``base_link``) is taken as
the controller's base frame, the chain starting at the link it is fixed to.

The package's modules, one job each: :mod:`.chain` reads the chain,
:mod:`.kinematics` turns it into an MDH table, :mod:`.limits` and
:mod:`.masses` read what the links carry, :mod:`.meshes` finds and reads
collision meshes, :mod:`.body` fits capsules to the collision geometry,
:mod:`.sweeps` narrows limits where the capsule check cannot see,
:mod:`.frames` finds the controller's frames and :mod:`.describe` puts them
together.
"""

from calibrator.robots.urdf.body import BARE_LINK_RADIUS_MM, FIT_MARGIN_MM, fit_body
from calibrator.robots.urdf.chain import (
    BASE_LINKS,
    MAX_BYTES,
    TIP_LINKS,
    Chain,
    Joint,
    origin_of,
    read_chain,
)
from calibrator.robots.urdf.describe import describe
from calibrator.robots.urdf.frames import REP199_BASE, REP199_FLANGE, controller_frame
from calibrator.robots.urdf.kinematics import Kinematics, joint_axes, kinematics_of, upright
from calibrator.robots.urdf.meshes import mesh_file
from calibrator.robots.urdf.sweeps import narrow_limits

__all__ = [
    "BARE_LINK_RADIUS_MM",
    "BASE_LINKS",
    "FIT_MARGIN_MM",
    "MAX_BYTES",
    "REP199_BASE",
    "REP199_FLANGE",
    "TIP_LINKS",
    "Chain",
    "Joint",
    "Kinematics",
    "controller_frame",
    "describe",
    "fit_body",
    "joint_axes",
    "kinematics_of",
    "mesh_file",
    "narrow_limits",
    "origin_of",
    "read_chain",
    "upright",
]
