"""Helpers the robot tests share."""

import time

import pytest


def wait_until(condition, timeout_s=3.0, what="condition"):
    """Poll ``condition`` until true; fail the test after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.002)
