"""The product's line protocol (ASCII frames with a CRC-16) over pyserial: one brand's folder.

The same file roles as every brand (``drivers/tracker/emscon/`` has them too):

- :mod:`~drivers.tracker.line.link` -- the transport: frames in and out, deadlines, reconnects.
- :mod:`~drivers.tracker.line.protocol` -- framing, CRC, command and reply grammar.
- :mod:`~drivers.tracker.line.device` -- :class:`LaserTracker`, the driver behind the
  ``Tracker`` port, and ``open_url`` (device paths, ``socket://``, ``rfc2217://``, ``loop://``).
- :mod:`~drivers.tracker.line.errors` -- the protocol's ``ER`` codes mapped onto the
  shared failures of :mod:`drivers.tracker.errors`.
- :mod:`~drivers.tracker.line.simulator` -- a tracker speaking the protocol; ``sim`` runs
  it as a child process (``python -m drivers.tracker.line.simulator``).
"""
