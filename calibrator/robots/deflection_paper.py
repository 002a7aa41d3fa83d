"""Chen and Zhang's example arm (the deflection paper, 1984), for the deflection analysis.

Not a calibration target: five axes, joint 3 a sliding rod. The paper's
Fig. 4 is missing from the text; the table below is our reading of it:
joint 1 turns the column about the vertical (s1 = 1100 mm); joint 2 pitches
the arm about a horizontal axis, the rod's axis h2 = 142 mm above it; joint 3
slides the rod (link 3, s3, 600 mm out at the end pose, clamped at frame 2);
joint 4 rolls about the rod, joint 5 turns the hand about the vertical with
the hand frame h5 = 260 mm below the rod's tip, z5 up, x5 across the arm.

Sources: the paper's example, its mass table (masses, centres of mass in m,
principal inertias in kg m^2; link 5 includes the 5 kg workpiece) and its
rod (hollow steel, E = 2.1e11 Pa, D = 0.05 m, d = 0.03 m).
"""

from __future__ import annotations

import numpy as np

_DEG = np.pi / 180.0

#: What reports call the arm.
TITLE = "Chen and Zhang example (5 axes, rod D 50 / d 30 mm)"
#: Standard DH rows ``[theta_offset, s, h, alpha]`` (rad, mm).
TABLE = np.array(
    [
        [0.0, 1100.0, 0.0, -90 * _DEG],
        [-90 * _DEG, 0.0, 142.0, -90 * _DEG],
        [0.0, 0.0, 0.0, 0.0],
        [-90 * _DEG, 0.0, 0.0, -90 * _DEG],
        [0.0, -260.0, 0.0, 0.0],
    ]
)
#: Which joints slide (their coordinate adds to ``s``, mm).
PRISMATIC = np.array([False, False, True, False, False])
#: Link masses (kg), link 5 with the 5 kg workpiece.
MASS_KG = np.array([61.46, 27.8, 18.72, 5.33, 6.5 + 5.0])
#: Centres of mass in link frame i (mm).
COM_MM = np.array([[0, -800, 0], [0, 0, 0], [0, 0, -400], [0, 0, 0], [-100, 0, 0]], dtype=float)
#: Principal inertias (kg m^2), in link frame i.
INERTIA_KG_M2 = np.array(
    [
        [0.15, 0.1, 0.172],
        [1.5, 1.8, 1.7],
        [1.3, 1.2, 1.1],
        [0.007, 0.009, 0.004],
        [0.01, 0.01, 0.014],
    ]
)
#: The flexible link (1-based) and its section: outer, inner diameter (mm), E (N/mm^2).
ROD_LINK = 3
ROD_OUTER_MM, ROD_INNER_MM, ROD_E_MPA = 50.0, 30.0, 2.1e5
#: The task: the hand's origin on a straight line while x5 turns from 0 to 45 deg
#: with theta_1, in 1 s. Our line: base x = 600 cos 45 deg, so the rod is out
#: s3 = 600 mm (the paper's s3') at the end.
DURATION_S = 1.0
LINE_X_MM = 600.0 * np.cos(45 * _DEG)
