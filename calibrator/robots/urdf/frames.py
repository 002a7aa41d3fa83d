"""The controller's base and flange frames in a URDF, by REP-199's link names."""

from __future__ import annotations

import numpy as np

from calibrator.robots.urdf.chain import (
    Chain,
    fixed_to,
    link_groups,
)

#: Links ROS-Industrial's support packages name after the controller's frames
#: (the REP-199 draft, "Coordinate Frames for Serial Industrial Manipulators"):
#: ``base`` is the controller's base (world) frame, ``tool0`` its flange with an
#: all-zero tool, so that tool0 looked up in base is the pose the pendant shows.
REP199_BASE = "base"
REP199_FLANGE = "tool0"


def controller_frame(chain: Chain, link: str, end: str) -> np.ndarray | None:
    """A link fixed to the chain's base (``end="base"``) or flange (``"flange"``), or None.

    Returns its pose (4, 4, mm) in the chain's base link, or in its tip link,
    found through fixed joints only; None when ``link`` is not in the file or
    not fixed to that end.
    """
    groups = link_groups(chain)
    group = groups[0] if end == "base" else groups[-1]
    if link not in {e.get("name") for e in chain.root.findall("link")}:
        return None
    found = fixed_to(chain.root, link, set(group))
    if found is None:
        return None
    anchor = chain.base_link if end == "base" else chain.tip_link
    if link == anchor:
        return np.eye(4)  # exactly: the chain's own end
    frames = chain.link_frames()
    return np.linalg.inv(frames[anchor]) @ frames[found[0]] @ found[1]


def controller_frames(chain: Chain) -> tuple[np.ndarray, np.ndarray, tuple[str, str]]:
    """The controller's base and flange frames of a chain, by REP-199's link names.

    A base link named with ``--base-link`` that is fixed beside the chain
    (:attr:`Chain.world_link`) is the base frame; else a link ``base`` fixed
    to the chain's base, else the chain's base link itself. The flange is a
    link ``tool0`` fixed to the tip, else the tip. A description file may
    name others (:mod:`calibrator.robots.files`).
    """
    name = chain.path.name
    world = chain.world_link or REP199_BASE
    base = controller_frame(chain, world, "base")
    flange = controller_frame(chain, REP199_FLANGE, "flange")
    why = "named as the base link" if chain.world_link else "REP-199's controller base frame"
    return (
        np.eye(4) if base is None else base,
        np.eye(4) if flange is None else flange,
        (
            "" if base is None else f"{name}: link {world!r} ({why})",
            "" if flange is None else f"{name}: link {REP199_FLANGE!r} (REP-199's all-zero tool)",
        ),
    )
