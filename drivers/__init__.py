"""Hardware adapters (laser tracker, robot), each behind a small interface.

Drivers never open ports they were not handed: every driver takes a URL,
host or already-open transport from its caller.
"""
