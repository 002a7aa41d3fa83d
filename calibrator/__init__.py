"""Geometric calibration of 6-axis robot arms measured by a laser tracker.

Domain code only: nothing in this package touches hardware. Lengths are
millimetres and angles radians throughout; frames are named ``a2b``.
"""

__version__ = "0.1.0"
