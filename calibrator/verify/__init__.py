"""``calibrator verify``: the ISO 9283 pose and path tests, their figures and their run.

The figures are ISO 9283's (:mod:`.iso9283`: AP, RP and the cube of test
poses; :mod:`.path_figures`: AT_P, RT_P, AV, RV, FV and the corner figures of
a path); the pose test's plan, the registration of the tracker and its
document are in :mod:`.pose`, the path test's plan and streamed run in
:mod:`.path`; :mod:`.procedure` runs the pose test as a cell procedure
(:mod:`calibrator.acquire.procedure`), callable from Python. Units: mm and
rad; figures in the robot base frame.
"""
