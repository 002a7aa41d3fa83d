"""Constants shared by the emScon tests (a module of its own: conftest is not importable)."""

from drivers.tracker.line.device import Environment

TARGET_MM = (2000.0, 300.0, -200.0)
ENV = Environment(21.5, 1002.5, 41.0)
