"""The emulated DAQ answers as the Modbus Application Protocol says (issue 52), checked with
a client that is not pymodbus (umodbus builds the valid requests and maps each exception code
to its own error class) and with raw frames for what no client library would send."""

from __future__ import annotations

import re
import socket
import struct
import time
from collections.abc import Iterator

import pytest
from umodbus import exceptions as mb
from umodbus.client import tcp

from pam_bench.buses.register_map import load_register_map
from pam_bench.twin.modbus_server import ModbusServer


@pytest.fixture(params=['daq_generic', 'labjack_t7'])
def server(request: pytest.FixtureRequest) -> Iterator[ModbusServer]:
    words: dict[int, int] = {}
    srv = ModbusServer(load_register_map(request.param), 0,
                       lambda kind, a, n: [words.get(b, b & 0xFF) for b in range(a, a + n)],
                       lambda a, ws: words.update({a + k: w for k, w in enumerate(ws)}))
    srv.start()
    try:
        yield srv
    finally:
        srv.stop()


def _connect(srv: ModbusServer) -> socket.socket:
    sock = socket.create_connection(('127.0.0.1', srv.port), timeout=5.0)
    return sock


def _ask(sock: socket.socket, adu: bytes) -> bytes:
    sock.sendall(adu)
    head = _exactly(sock, 7)
    return head + _exactly(sock, struct.unpack('>H', head[4:6])[0] - 1)


def _exactly(sock: socket.socket, n: int) -> bytes:
    out = b''
    while len(out) < n:
        chunk = sock.recv(n - len(out))
        assert chunk, 'the server closed the connection'
        out += chunk
    return out


def _raw(pdu: bytes, tid: int = 7, pid: int = 0, unit: int = 1) -> bytes:
    return struct.pack('>HHHB', tid, pid, len(pdu) + 1, unit) + pdu


def _readable(srv: ModbusServer) -> tuple[int, int]:
    """(function code, address) of a register the map lets a master read."""
    c = srv.map.inputs[0]
    return (4 if c.register == 'input' else 3), c.address


def test_valid_requests_of_another_client_are_answered(server: ModbusServer) -> None:
    fc, address = _readable(server)
    build = tcp.read_input_registers if fc == 4 else tcp.read_holding_registers
    with _connect(server) as sock:
        req = build(1, address, 2)
        assert tcp.parse_response_adu(_ask(sock, req), req) == [address & 0xFF,
                                                               (address + 1) & 0xFF]
        out = server.map.outputs[0]
        req = tcp.write_multiple_registers(1, out.address, [0x4120, 0x0000])
        assert tcp.parse_response_adu(_ask(sock, req), req) == 2


@pytest.mark.parametrize('case, code, error', [
    ('quantity 126', 0x03, mb.IllegalDataValueError),
    ('quantity 0', 0x03, mb.IllegalDataValueError),
    ('write quantity 124', 0x03, mb.IllegalDataValueError),
    ('byte count off', 0x03, mb.IllegalDataValueError),
    ('short PDU', 0x03, mb.IllegalDataValueError),
    ('unknown function 0x2B', 0x01, mb.IllegalFunctionError),
    ('function 1 (coils)', 0x01, mb.IllegalFunctionError),
    ('no such register', 0x02, mb.IllegalDataAddressError),
])
def test_each_malformed_request_gets_the_specified_exception(server: ModbusServer, case: str,
                                                             code: int,
                                                             error: type[Exception]) -> None:
    fc, address = _readable(server)
    out = server.map.outputs[0].address
    pdu = {'quantity 126': struct.pack('>BHH', fc, address, 126),
           'quantity 0': struct.pack('>BHH', fc, address, 0),
           'write quantity 124': struct.pack('>BHHB', 16, out, 124, 248) + b'\0' * 200,
           'byte count off': struct.pack('>BHHB', 16, out, 2, 3) + b'\0' * 3,
           'short PDU': struct.pack('>BH', fc, address),
           'unknown function 0x2B': bytes([0x2B, 0x0E, 0x01, 0x00]),
           'function 1 (coils)': struct.pack('>BHH', 1, 0, 8),
           'no such register': struct.pack('>BHH', fc, 20000, 2)}[case]
    with _connect(server) as sock:
        reply = _ask(sock, _raw(pdu))
        assert reply[7:] == bytes([pdu[0] | 0x80, code]), (case, reply.hex())
        with pytest.raises(error):                  # umodbus reads it as that exception
            tcp.raise_for_exception_adu(reply)


def test_the_access_the_device_gives_is_the_access_it_has() -> None:
    """The T7's TDAC is written only and its AIN read only, through either read function;
    the generic DAQ's input registers are not its holding registers."""
    words: dict[int, int] = {}
    t7 = ModbusServer(load_register_map('labjack_t7'), 0, lambda k, a, n: [0] * n,
                      lambda a, ws: words.update({a: ws[0]}))
    assert t7.answer(struct.pack('>BHH', 3, 0, 4))[0] == 3          # AIN0, AIN1 by FC 3
    assert t7.answer(struct.pack('>BHH', 4, 0, 4))[0] == 4          # and by FC 4
    assert t7.answer(struct.pack('>BHH', 3, 30008, 2)) == b'\x83\x02'   # TDAC4: no read
    assert t7.answer(struct.pack('>BHHB', 16, 0, 2, 4) + b'\0' * 4) == b'\x90\x02'  # AIN
    assert t7.answer(struct.pack('>BHHB', 16, 30008, 2, 4) + b'\0' * 4)[0] == 16
    generic = ModbusServer(load_register_map('daq_generic'), 0, lambda k, a, n: [0] * n,
                           lambda a, ws: None)
    assert generic.answer(struct.pack('>BHH', 4, 0, 8))[0] == 4
    assert generic.answer(struct.pack('>BHH', 3, 4, 2)) == b'\x83\x02'  # holding 4: none


def test_a_malformed_header_never_stalls_the_next_request(server: ModbusServer) -> None:
    fc, address = _readable(server)
    good = _raw(struct.pack('>BHH', fc, address, 2), tid=9)
    with _connect(server) as sock:
        sock.sendall(_raw(struct.pack('>BHH', fc, address, 2), pid=5))   # not Modbus: skipped
        reply = _ask(sock, good)
        assert struct.unpack('>H', reply[:2])[0] == 9 and reply[7] == fc
    with _connect(server) as sock:                      # a length no frame has: closed
        sock.sendall(struct.pack('>HHHB', 1, 0, 0xFFFF, 1))
        assert sock.recv(16) == b''
    with _connect(server) as sock:                      # and the next connection is served
        assert _ask(sock, good)[7] == fc


def test_a_frame_left_half_sent_ends_its_connection_only(server: ModbusServer,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    from pam_bench.twin import modbus_server
    monkeypatch.setattr(modbus_server, 'FRAME_TIMEOUT_S', 0.2)
    fc, address = _readable(server)
    good = _raw(struct.pack('>BHH', fc, address, 2), tid=11)
    with _connect(server) as sock:
        sock.sendall(good + good[:9])        # one whole request, then half of the next
        reply = _exactly(sock, 7 + 2 + 4)
        assert struct.unpack('>H', reply[:2])[0] == 11 and reply[7] == fc
        t0 = time.monotonic()
        assert sock.recv(16) == b''          # the half frame: dropped with its connection
        assert 0.15 < time.monotonic() - t0 < 2.0
    with _connect(server) as sock:
        assert _ask(sock, good)[7] == fc


def test_requests_sent_together_are_answered_in_order(server: ModbusServer) -> None:
    fc, address = _readable(server)
    reqs = [_raw(struct.pack('>BHH', fc, address, 2), tid=t) for t in (21, 22, 23)]
    with _connect(server) as sock:
        sock.sendall(b''.join(reqs))
        tids = [struct.unpack('>H', _exactly(sock, 13)[:2])[0] for _ in reqs]
    assert tids == [21, 22, 23]


# --- LabJack's published Modbus map, line by line ------------------------------------------

LABJACK = {  # name: (start address, type, access), from ljm_constants.json (the Modbus Map)
    'AIN#': (0, 'FLOAT32', 'r'),
    'DAC#': (1000, 'FLOAT32', 'rw'),
    'DIO#_EF_READ_A': (3000, 'UINT32', 'r'),
    'TDAC#': (30000, 'FLOAT32', 'w'),
}
"""Registers of the T7 the map uses; each # adds two registers (32-bit values). A TDAC pair
follows the FIO pair it is plugged into: FIO2/FIO3 -> TDAC2 (DACA) and TDAC3 (DACB)."""


def test_the_t7_map_is_labjacks_line_by_line() -> None:
    m = load_register_map('labjack_t7')
    assert m.address_space == 'unified' and m.watchdog_s == 0.0    # no TDAC watchdog
    wiring = {'load_cell_1.force': ('AIN#', 0), 'valve_1.pressure': ('AIN#', 1),
              'encoder.angle': ('DIO#_EF_READ_A', 0),               # FIO0/FIO1, quadrature
              'valve_1.voltage': ('TDAC#', 4)}                       # LJTick-DAC on FIO4/FIO5
    for c in m.channels:
        name, n = wiring[c.signal]
        start, kind, access = LABJACK[name]
        assert c.address == start + 2 * n, c.signal
        assert c.access == access, c.signal
        assert c.type == kind.lower() or (kind, c.type) == ('UINT32', 'int32'), c.signal
    fio = {'encoder.angle': {0, 1}, 'valve_1.voltage': {4, 5}}      # no pin used twice
    assert not fio['encoder.angle'] & fio['valve_1.voltage']
    for d in m.device_registers:
        start, _, access = LABJACK[re.sub(r'\(.*?\)', '', d.name)]
        assert (d.address, d.access) == (start, access), d.name
