"""The drivers' one exception tree.

Every failure a driver reports is a :class:`DriverError` (an ``IOError``),
so the CLI can map the whole family to a one-line message. Sub-packages
(``drivers.tracker``, ``drivers.robot``) derive their specific errors from
these classes rather than starting trees of their own.
"""


class DriverError(IOError):
    """Base of every error raised by a hardware driver."""


class DriverTimeout(DriverError, TimeoutError):
    """A reply or state change did not arrive by its deadline."""


class ProtocolError(DriverError):
    """A frame was malformed, failed its checksum, or made no sense here."""


class ConnectionLost(DriverError, ConnectionError):
    """The transport to the device went away (port vanished, peer hung up)."""


class NotReady(DriverError):
    """The device is not in a state that allows the command (e.g. not initialised)."""
