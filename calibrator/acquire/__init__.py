"""Acquisition: the measure loop and the two ports it drives (tracker, robot).

Domain logic only: this package defines the ports in :mod:`calibrator.acquire.ports`
and never imports a concrete driver. The CLI builds drivers (``drivers/``) and
hands them in.
"""
