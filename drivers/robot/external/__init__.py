"""The ``external`` robot kind: an arm that runs the plan as its own program.

For any brand: load the program from ``calibrator program`` on the
controller, start it, and measure with ``--robot external``. See
``docs/external-robots.md``. There is no driver: the kind opens a
:class:`calibrator.acquire.external.arm.ProgramArm`, and stop detection and
association are acquisition logic in :mod:`calibrator.acquire.external`.
The ISO 9283 path test runs the same way: the controller runs the program
``calibrator program --path`` writes while ``verify --path --robot external``
streams the tracker (:mod:`calibrator.verify.path_external`).
"""

from drivers.robot.external.setup import open_external

__all__ = ["open_external"]
