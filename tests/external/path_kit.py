"""What the path program tests share: verify's commanded path, the flange to the reflector."""

from __future__ import annotations

import numpy as np

from calibrator.model import frames
from calibrator.verify import path as verify_path
from calibrator.verify import pose

#: The reflector on the flange verify and program use by default, mm.
TOOL = (0.0, 0.0, 100.0)


def commanded(arm, shape: str):
    """Verify's commanded path and tool rotation for this arm (default cube, no tracker)."""
    tool = frames.transform(translation=TOOL)
    vplan = pose.make_plan(arm, tool, 2)
    rotation = vplan.desired[0][:3, :3]
    return verify_path.test_path(shape, vplan.cube, rotation), rotation


def reflector(arm, flange_in_controller: np.ndarray) -> np.ndarray:
    """The reflector of the controller's flange poses (K, 4, 4), the model's base frame, (K, 3)."""
    model = (
        arm.model_base2controller_base
        @ flange_in_controller
        @ frames.invert(arm.model_flange2controller_flange)
    )
    return (model @ frames.transform(translation=TOOL))[:, :3, 3]
