"""The DAQ driver's Modbus TCP master (``buses.modbus_io``) against the strict emulated server
and against servers that answer wrongly: one round trip per exchange, every mismatch one
``BusUnreachable``."""

from __future__ import annotations

import socket
import struct
import threading
import time
from collections.abc import Callable, Iterator

import pytest

from pam_bench.buses.errors import BusUnreachable
from pam_bench.buses.modbus_io import ModbusIo
from pam_bench.buses.register_map import load_register_map
from pam_bench.twin.modbus_server import ModbusServer

Reply = Callable[[int, bytes], bytes | None]
"""(transaction id, request PDU) -> the whole ADU to send back (None: say nothing)."""


@pytest.fixture
def words() -> dict[tuple[str, int], int]:
    return {}


@pytest.fixture
def server(words: dict[tuple[str, int], int]) -> Iterator[ModbusServer]:
    rmap = load_register_map('daq_generic')

    def write(address: int, ws: list[int]) -> None:
        for k, w in enumerate(ws):
            words[('holding', address + k)] = w

    srv = ModbusServer(rmap, 0,
                       lambda kind, a, n: [words.get((kind, b), 0) for b in range(a, a + n)],
                       write).start()
    try:
        yield srv
    finally:
        srv.stop()


def test_an_exchange_writes_and_reads_in_one_round_trip(
        server: ModbusServer, words: dict[tuple[str, int], int]) -> None:
    rmap = load_register_map('daq_generic')
    force = rmap.channel('load_cell_1.force')
    assert force is not None
    for k, w in enumerate(rmap.encode(force, 123.5)):
        words[('input', force.address + k)] = w
    io = ModbusIo(rmap, '127.0.0.1', server.port, timeout_s=1.0)
    io.connect()
    try:
        values = io.exchange({'valve_1.voltage': 2.5})
        assert io.take_round_trips().__len__() == 1
        assert values['load_cell_1.force'] == pytest.approx(123.5)
        valve = rmap.channel('valve_1.voltage')
        assert valve is not None
        written = [words[('holding', valve.address + k)] for k in range(valve.count)]
        assert rmap.decode(valve, written) == pytest.approx(2.5)
        for _ in range(200):                      # transaction ids keep in step
            io.exchange({'valve_1.voltage': 1.0})
        assert server.exceptions == {}
    finally:
        io.close()


class FakeServer:
    """Answers each request as ``reply`` says (a server that misbehaves)."""

    def __init__(self, reply: Reply, trickle: bool = False) -> None:
        self.reply, self.trickle = reply, trickle
        self.sock = socket.create_server(('127.0.0.1', 0))
        self.port = self.sock.getsockname()[1]
        self.thread = threading.Thread(target=self._serve, daemon=True)
        self.thread.start()

    def _serve(self) -> None:
        conn, _ = self.sock.accept()
        with conn:
            buf = b''
            while True:
                try:
                    chunk = conn.recv(4096)
                except OSError:
                    return
                if not chunk:
                    return
                buf += chunk
                while len(buf) >= 7:
                    tid, _, length, _ = struct.unpack('>HHHB', buf[:7])
                    if len(buf) < 6 + length:
                        break
                    pdu, buf = buf[7:6 + length], buf[6 + length:]
                    out = self.reply(tid, pdu)
                    if out is None:
                        continue
                    if out == b'':
                        conn.close()
                        return
                    try:
                        if self.trickle:
                            for k in range(len(out)):
                                conn.sendall(out[k:k + 1])     # a byte per segment
                                time.sleep(0.0005)
                        else:
                            conn.sendall(out)
                    except OSError:             # the client gave up first: it may
                        return

    def close(self) -> None:
        self.sock.close()


def adu(tid: int, pdu: bytes) -> bytes:
    return struct.pack('>HHHB', tid, 0, len(pdu) + 1, 1) + pdu


def normal(tid: int, pdu: bytes) -> bytes:
    if pdu[0] == 16:
        return adu(tid, pdu[:5])
    qty = struct.unpack('>H', pdu[3:5])[0]
    return adu(tid, bytes([pdu[0], 2 * qty]) + b'\0' * 2 * qty)


@pytest.mark.parametrize('reply, says', [
    (lambda tid, pdu: normal(tid + 1, pdu), 'out of step'),
    (lambda tid, pdu: adu(tid, bytes([pdu[0] | 0x80, 0x02])), 'exception 0x02'),
    (lambda tid, pdu: adu(tid, bytes([4 if pdu[0] == 16 else 16]) + pdu[1:5]),
     'does not answer'),
    (lambda tid, pdu: adu(tid, pdu[:5]) if pdu[0] == 16 else adu(tid, b'\x04\x02\0\0'),
     '2 bytes for 8 registers'),
    (lambda tid, pdu: None, 'timed out'),
    (lambda tid, pdu: struct.pack('>HHHB', tid, 0, 300, 1), 'length 300'),
    (lambda tid, pdu: b'', 'closed|reset'),       # a FIN, or an RST over unread bytes
], ids=['transaction', 'exception', 'function', 'count', 'silent', 'length', 'hang-up'])
def test_a_wrong_answer_is_one_bus_error(reply: Reply, says: str) -> None:
    fake = FakeServer(reply)
    io = ModbusIo(load_register_map('daq_generic'), '127.0.0.1', fake.port, timeout_s=0.2)
    try:
        io.connect()
        with pytest.raises(BusUnreachable, match=says):
            io.exchange({'valve_1.voltage': 1.0})
    finally:
        io.close()
        fake.close()


def test_replies_cut_anywhere_are_read_whole() -> None:
    """The replies to one exchange may come in any number of segments (here a byte each)."""
    rmap = load_register_map('daq_generic')
    force = rmap.channel('load_cell_1.force')
    assert force is not None
    fake = FakeServer(normal, trickle=True)
    io = ModbusIo(rmap, '127.0.0.1', fake.port, timeout_s=1.0)
    try:
        io.connect()
        for _ in range(3):                        # and the next exchange stays in step
            values = io.exchange({'valve_1.voltage': 1.0})
            assert values['load_cell_1.force'] == rmap.decode(force, [0] * force.count)
    finally:
        io.close()
        fake.close()


def test_not_connected_is_a_bus_error() -> None:
    io = ModbusIo(load_register_map('daq_generic'), '127.0.0.1', 1)
    with pytest.raises(BusUnreachable, match='not connected'):
        io.read_inputs()
