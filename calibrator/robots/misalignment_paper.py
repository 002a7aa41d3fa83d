"""The misalignment paper's arm (reference paper 000), for the joint-clearance analysis.

Not a calibration target: the paper gives a Craig modified-DH table and one
pose, which :func:`calibrator.analysis.arm.build` turns into a posed arm.

Source: the paper's Table 2 (link table) and its pose.
"""

from __future__ import annotations

import numpy as np

#: What reports call the arm.
TITLE = "paper arm (the misalignment paper, Table 2)"

#: Craig modified DH, rows ``[alpha_{i-1} (deg), a_{i-1} (mm), d_i (mm)]``.
CRAIG_TABLE = np.array(
    [
        [0.0, 0.0, 0.0],
        [-90.0, 200.0, 0.0],
        [90.0, 200.0, 1000.0],
        [0.0, 0.0, 1000.0],
        [0.0, 200.0, 100.0],
        [0.0, 0.0, 100.0],
    ]
)
#: The paper's pose, joint angles theta_1..6 (deg).
POSE_DEG = np.array([100.0, 60.0, -10.0, -120.0, 90.0, 0.0])
