"""Independent references for tests: built with scipy, never with calibrator's own frames code."""

import numpy as np


def homogeneous(rotation=None, translation=(0.0, 0.0, 0.0)):
    """4x4 transform: a scipy ``Rotation`` (None: identity), then a translation."""
    t = np.eye(4)
    if rotation is not None:
        t[:3, :3] = rotation.as_matrix()
    t[:3, 3] = translation
    return t
