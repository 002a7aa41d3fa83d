"""One RTDE v2 connection of the fake controller (port 30004).

Answers setup requests in the order they arrive, keeps the input recipes of
this connection (ids 1..N, as the ``ur-rtde`` client assumes), writes the
client's input registers into the controller, and streams ``U`` packages at
the negotiated rate once started. The stream never stalls on its own: the
client's receive thread dies after 2.5 s without data.
"""

from __future__ import annotations

import socket
import struct
import threading
import time
from typing import TYPE_CHECKING

from drivers.robot.ur.simulator import wire

if TYPE_CHECKING:
    from drivers.robot.ur.simulator.controller import FakeController

CONTROLLER_VERSION = (5, 11, 1, 108318)


def _read_exact(conn, n):
    data = b""
    while len(data) < n:
        chunk = conn.recv(n - len(data))
        if not chunk:
            raise ConnectionError("peer closed")
        data += chunk
    return data


class RtdeSession:
    """One RTDE connection: answers setup requests in order, then streams outputs."""

    def __init__(
        self, conn: socket.socket, controller: FakeController, server_stopped: threading.Event
    ) -> None:
        self.conn = conn
        self.controller = controller
        self.server_stopped = server_stopped
        self.send_lock = threading.Lock()
        self.output_names: list[str] = []
        self.output_types: list[str] = []
        self.output_struct: struct.Struct | None = None
        self.frequency = 500.0
        # recipe id -> (names, values per field, struct)
        self.inputs: dict[int, tuple[list[str], list[int], struct.Struct]] = {}
        self.streaming = threading.Event()
        self.closed = False

    def send(self, package_type: int, payload: bytes = b"") -> None:
        with self.send_lock:
            self.conn.sendall(wire.pack(package_type, payload))

    def run(self) -> None:
        threading.Thread(target=self._stream, daemon=True).start()
        try:
            while not self.server_stopped.is_set():
                size, package_type = wire.HEADER.unpack(_read_exact(self.conn, wire.HEADER.size))
                payload = _read_exact(self.conn, size - wire.HEADER.size)
                self._handle(package_type, payload)
        finally:
            self.closed = True

    def _handle(self, package_type, payload):
        if package_type == wire.REQUEST_PROTOCOL_VERSION:
            self.send(package_type, b"\x01")
        elif package_type == wire.GET_URCONTROL_VERSION:
            self.send(package_type, struct.pack(">IIII", *CONTROLLER_VERSION))
        elif package_type == wire.SETUP_OUTPUTS:
            (frequency,) = struct.unpack(">d", payload[:8])
            self.frequency = frequency if frequency > 0 else 500.0
            self.output_names = wire.split_names(payload[8:])
            types = [wire.type_of(n) for n in self.output_names]
            self.output_types = types
            self.output_struct = wire.recipe_struct(types)
            self.send(package_type, b"\x01" + ",".join(types).encode())
        elif package_type == wire.SETUP_INPUTS:
            names = wire.split_names(payload)
            types = [wire.type_of(n) for n in names]
            recipe_id = len(self.inputs) + 1
            counts = [wire.count_of(t) for t in types]
            self.inputs[recipe_id] = (names, counts, wire.recipe_struct(types))
            self.send(package_type, bytes([recipe_id]) + ",".join(types).encode())
        elif package_type == wire.START:
            self.streaming.set()
            self.send(package_type, b"\x01")
        elif package_type == wire.PAUSE:
            self.streaming.clear()
            self.send(package_type, b"\x01")
        elif package_type == wire.DATA_PACKAGE:
            self._receive_inputs(payload)
        # anything else (text messages) needs no answer

    def _receive_inputs(self, payload):
        recipe = self.inputs.get(payload[0])
        if recipe is None:
            return
        names, counts, recipe_struct = recipe
        body = payload[1:]
        if len(body) < recipe_struct.size:
            return  # a short package cannot be trusted; the real controller drops it too
        values = recipe_struct.unpack_from(body)
        fields, at = {}, 0
        for name, count in zip(names, counts, strict=True):
            fields[name] = values[at] if count == 1 else values[at : at + count]
            at += count
        self.controller.write_inputs(fields)

    def _stream(self):
        """Stream ``U`` packages at the negotiated rate until the connection ends.

        A package goes out after every k-th controller cycle (k = the
        controller's rate over the negotiated one: 1 at 500 Hz), so each one
        carries the joints and timestamp of a new cycle, as on a controller.
        """
        seen = self.controller.cycles
        while not (self.server_stopped.is_set() or self.closed):
            if not self.streaming.wait(0.05):
                continue
            if self.controller.stalled:
                time.sleep(0.01)
                continue
            every = max(round(1.0 / (self.frequency * self.controller.period_s)), 1)
            cycles = self.controller.wait_cycle(seen + every - 1, 0.05)
            if cycles < seen + every:
                continue  # no cycle came (a stalled clock): look at the flags again
            seen = cycles
            try:
                self.send(wire.DATA_PACKAGE, b"\x01" + self._pack_outputs())
            except OSError:
                return

    def _pack_outputs(self):
        snapshot = self.controller.snapshot()
        flat = []
        for name, type_name in zip(self.output_names, self.output_types, strict=True):
            value = snapshot.get(name)
            if value is None:
                flat.extend(wire.zero_of(type_name))
            elif isinstance(value, tuple):
                flat.extend(value)
            else:
                flat.append(value)
        return self.output_struct.pack(*flat)
