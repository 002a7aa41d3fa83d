"""A man in the middle between the adapter and the emScon simulator: one reading of ten wild.

The proxy is a real TCP relay that adds 50 mm to ``dVal1`` of every tenth
``SingleMeasResult`` it passes on (well-formed packets, plausible values: only
the averaging can tell). ``calibrator measure`` runs through it as through a
tracker; every pose must come out as if the proxy were not there.
"""

from __future__ import annotations

import json
import socket
import struct
import threading

import numpy as np
import pyarrow.parquet as pq
import pytest
from cli_process_kit import run_cli

from drivers.tracker.emscon import protocol as pk
from drivers.tracker.emscon.simulator import EmsconSimulatorProcess

SHIFT_MM = 50.0
DVAL1 = pk.SIZE_COMMAND + 8  # header, status, measMode, bIsTryMode, then dVal1


class ShiftingProxy:
    """Relays 127.0.0.1:port to the server, shifting the 6th result of every 10."""

    def __init__(self, upstream_port: int):
        self.upstream_port = upstream_port
        self.results = 0
        self.shifted = 0
        self._listener = socket.create_server(("127.0.0.1", 0))
        self.port = self._listener.getsockname()[1]
        self._socks: list[socket.socket] = []
        threading.Thread(target=self._accept, daemon=True).start()

    def close(self) -> None:
        for s in [self._listener, *self._socks]:
            try:
                s.close()
            except OSError:
                pass

    def _accept(self) -> None:
        while True:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            server = socket.create_connection(("127.0.0.1", self.upstream_port))
            self._socks += [client, server]
            threading.Thread(target=self._pump, args=(client, server, False), daemon=True).start()
            threading.Thread(target=self._pump, args=(server, client, True), daemon=True).start()

    def _pump(self, src: socket.socket, dst: socket.socket, edit: bool) -> None:
        buf = bytearray()
        try:
            while chunk := src.recv(65536):
                if not edit:
                    dst.sendall(chunk)
                    continue
                buf += chunk
                while len(buf) >= 8:
                    size, type_ = pk.HEADER.unpack_from(buf)
                    if len(buf) < size:
                        break
                    packet = bytearray(buf[:size])
                    del buf[:size]
                    if type_ == pk.DataType.SINGLE_MEAS_RESULT:
                        self.results += 1
                        if self.results % 10 == 6:
                            (x,) = struct.unpack_from("<d", packet, DVAL1)
                            struct.pack_into("<d", packet, DVAL1, x + SHIFT_MM)
                            self.shifted += 1
                    dst.sendall(packet)
        except OSError:
            pass
        finally:
            for s in (src, dst):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass


@pytest.fixture
def proxied_sim():
    with EmsconSimulatorProcess(seed=4, initialised=True) as sim:
        proxy = ShiftingProxy(sim.port)
        try:
            yield sim, proxy
        finally:
            proxy.close()


def test_one_wild_reading_of_ten_never_moves_a_recorded_pose(tmp_path, proxied_sim):
    sim, proxy = proxied_sim
    done = run_cli(
        "measure", "--poses", "24", "--tracker", f"emscon://127.0.0.1:{proxy.port}",
        "--robot", f"sim://?control={sim.control_url}", "-o", "s.parquet", "--yes", cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert proxy.shifted >= 24  # every pose got its wild reading
    table = pq.read_table(tmp_path / "s.parquet").to_pydict()
    assert table["pose"] == list(range(24))
    assert set(table["n_readings"]) == {9}  # the wild one left out of every mean
    spread = np.column_stack([table[c] for c in ("sx_mm", "sy_mm", "sz_mm")])
    assert spread.max() < 0.05  # with it: about 15.8 mm on x
    ident = run_cli("identify", "s.parquet", "-o", "cal.json", cwd=tmp_path)
    assert ident.returncode == 0, ident.stderr
    held_out = json.loads((tmp_path / "cal.json").read_text())["stats"]["validation"]
    assert held_out["after"]["position_mm"]["mean"] < 0.05  # a 5 mm error would show here
