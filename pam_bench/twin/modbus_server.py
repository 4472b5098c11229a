"""A Modbus TCP server as strict as the Modbus Application Protocol and the device's map.

What the emulated DAQ answers (MODBUS Application Protocol Specification V1.1b3, and MODBUS
Messaging on TCP/IP Implementation Guide V1.0b):

* function codes 3 and 4 (read holding / input registers, 1 to 125 registers), 6 (write one
  register) and 16 (write 1 to 123 registers); any other code gets exception 01 (illegal
  function) with the code + 0x80;
* a quantity outside its range, or a byte count or a PDU length that does not match it, gets
  exception 03 (illegal data value);
* a register the device does not have, or one it does not let a master read or write
  (``RegisterMap.access_of``: a LabJack TDAC is written only, an AIN read only; in a unified
  address space both read functions reach every readable register), gets exception 02
  (illegal data address);
* an MBAP header whose protocol identifier is not 0 is skipped, its PDU read and dropped, with
  no answer (the guide's rule); one whose length field cannot be a Modbus frame (below 2 or
  above 254 bytes) ends the connection, as the stream cannot be read in frames after it; a
  frame left half sent is dropped after ``FRAME_TIMEOUT_S``. A later request on the same or a
  new connection is answered as usual: nothing stalls.
* a read is answered from one snapshot of the registers: a 32-bit value is never torn between
  two samples (a float whose words came from two samples would be a value the device never
  measured).
* the unit identifier is not checked: a Modbus TCP device (LabJack's T7 among them) answers
  whatever unit a master names; the map's ``device_id`` is what the driver sends.

The server runs an asyncio loop in a thread of its own on 127.0.0.1 (or ``host``), one protocol
object per connection that cuts the stream into frames itself (no stream reader, no timeout
task per frame: the emulated DAQ's thread took 159 us of CPU per exchange that way, see
docs/long_runs.md, "The emulated DAQ's server made cheaper, and real-time tried again"); the
registers are the caller's, through ``read`` and ``write``.
"""

from __future__ import annotations

import asyncio
import contextlib
import struct
import threading
from collections.abc import Callable

from pam_bench.buses.errors import BusUnreachable
from pam_bench.buses.modbus_io import MBAP
from pam_bench.buses.register_map import RegisterMap

__all__ = ['ModbusServer', 'FRAME_TIMEOUT_S', 'ILLEGAL_FUNCTION', 'ILLEGAL_ADDRESS',
           'ILLEGAL_VALUE']

FRAME_TIMEOUT_S = 2.0
"""How long the rest of a frame may take once its header came (s)."""
ILLEGAL_FUNCTION, ILLEGAL_ADDRESS, ILLEGAL_VALUE = 0x01, 0x02, 0x03
"""The exception codes the server answers with."""

Read = Callable[[str, int, int], list[int]]
"""(register kind 'input' or 'holding', first address, quantity) -> the 16-bit words there,
taken at one instant (a device answers a request from one snapshot of its registers, so the
two words of a 32-bit value never come from two different samples)."""
Write = Callable[[int, list[int]], None]
"""(first address, words) written to holding registers."""


class ModbusServer:
    """A Modbus TCP server over a register map (module docstring).

    Args:
        register_map: the device's registers and what a master may do with them.
        port: TCP port (0: any free one; ``port`` holds it once started).
        read: the words of a request, from one snapshot.
        write: keep words written.
        host: the address to listen on.
    """

    def __init__(self, register_map: RegisterMap, port: int, read: Read, write: Write,
                 host: str = '127.0.0.1') -> None:
        self.map, self.port, self.host = register_map, port, host
        self.read, self.write = read, write
        self.exceptions: dict[int, int] = {}         # exception code -> times answered
        self._loop: asyncio.AbstractEventLoop | None = None
        self._server: asyncio.AbstractServer | None = None
        self._thread: threading.Thread | None = None
        self._transports: set[asyncio.BaseTransport] = set()
        self._access: dict[tuple[str, int], str] = {}

    # --- life ---------------------------------------------------------------------------
    def start(self) -> ModbusServer:
        """Listen, in a thread of its own; returns self.

        Raises:
            BusUnreachable: the port cannot be had (one line).
        """
        ready = threading.Event()
        failed: list[BaseException] = []

        def serve() -> None:
            loop = asyncio.new_event_loop()
            self._loop = loop
            try:
                self._server = loop.run_until_complete(
                    loop.create_server(self._connection, self.host, self.port))
                self.port = self._server.sockets[0].getsockname()[1]
            except BaseException as exc:  # noqa: BLE001 - reported to the starter
                failed.append(exc)
                ready.set()
                loop.close()
                return
            ready.set()
            loop.run_forever()
            loop.run_until_complete(loop.shutdown_asyncgens())
            loop.close()

        self._thread = threading.Thread(target=serve, daemon=True, name='modbus-server')
        self._thread.start()
        ready.wait(10.0)
        if failed:
            raise BusUnreachable(f'Modbus server: cannot listen on {self.host}:{self.port}: '
                                 f'{failed[0]}')
        return self

    def stop(self) -> None:
        """Close the server and every connection."""
        loop, server = self._loop, self._server
        if loop is None or loop.is_closed():
            return

        async def close() -> None:
            if server is not None:
                server.close()
                with contextlib.suppress(Exception):
                    await asyncio.wait_for(server.wait_closed(), 2.0)
            for transport in list(self._transports):
                transport.close()
        with contextlib.suppress(Exception):
            asyncio.run_coroutine_threadsafe(close(), loop).result(5.0)
        with contextlib.suppress(RuntimeError):
            loop.call_soon_threadsafe(loop.stop)
        if self._thread is not None:
            self._thread.join(5.0)
        self._server = None

    # --- one connection -------------------------------------------------------------------
    def _connection(self) -> asyncio.Protocol:
        return _Connection(self)

    def answer(self, pdu: bytes) -> bytes:
        """The response PDU to a request PDU (module docstring)."""
        fc = pdu[0]
        body = pdu[1:]
        if fc in (3, 4):
            if len(body) != 4:
                return self._exception(fc, ILLEGAL_VALUE)
            start, qty = struct.unpack('>HH', body)
            if not 1 <= qty <= 125:
                return self._exception(fc, ILLEGAL_VALUE)
            kind = 'holding' if fc == 3 else 'input'
            if start + qty > 65536 or not all(
                    'r' in self._access_of(kind, a) for a in range(start, start + qty)):
                return self._exception(fc, ILLEGAL_ADDRESS)
            words = [w & 0xFFFF for w in self.read(kind, start, qty)]
            return struct.pack(f'>BB{qty}H', fc, 2 * qty, *words)
        if fc == 6:
            if len(body) != 4:
                return self._exception(fc, ILLEGAL_VALUE)
            address, value = struct.unpack('>HH', body)
            if 'w' not in self._access_of('holding', address):
                return self._exception(fc, ILLEGAL_ADDRESS)
            self.write(address, [value])
            return pdu
        if fc == 16:
            if len(body) < 5:
                return self._exception(fc, ILLEGAL_VALUE)
            start, qty, nbytes = struct.unpack('>HHB', body[:5])
            if not 1 <= qty <= 123 or nbytes != 2 * qty or len(body) != 5 + nbytes:
                return self._exception(fc, ILLEGAL_VALUE)
            if start + qty > 65536 or not all(
                    'w' in self._access_of('holding', a) for a in range(start, start + qty)):
                return self._exception(fc, ILLEGAL_ADDRESS)
            self.write(start, list(struct.unpack(f'>{qty}H', body[5:])))
            return struct.pack('>BHH', fc, start, qty)
        return self._exception(fc, ILLEGAL_FUNCTION)

    def _access_of(self, kind: str, address: int) -> str:
        """``RegisterMap.access_of``, kept per register once asked (the map does not change)."""
        key = (kind, address)
        access = self._access.get(key)
        if access is None:
            access = self._access[key] = self.map.access_of(kind, address)
        return access

    def _exception(self, fc: int, code: int) -> bytes:
        self.exceptions[code] = self.exceptions.get(code, 0) + 1
        return bytes([(fc | 0x80) & 0xFF, code])


class _Connection(asyncio.Protocol):
    """One master's connection: the bytes as they come are cut into frames, every whole
    request in them answered, the answers sent back in one write (a master that sends its
    write and its read together gets both replies in one segment). A frame still partial
    ``FRAME_TIMEOUT_S`` after it began ends the connection; so does a length field no frame
    can have (module docstring)."""

    def __init__(self, server: ModbusServer) -> None:
        self.server = server
        self.buffer = bytearray()
        self.transport: asyncio.Transport | None = None
        self.timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        self.server._transports.add(transport)

    def connection_lost(self, exc: Exception | None) -> None:
        if self.transport is not None:
            self.server._transports.discard(self.transport)
        self._stop_timer()

    def data_received(self, data: bytes) -> None:
        assert self.transport is not None
        buf = self.buffer
        buf += data
        replies: list[bytes] = []
        framed = False
        while len(buf) >= 7:
            tid, pid, length, unit = MBAP.unpack_from(buf)
            if not 2 <= length <= 254:           # no frame can follow: the stream is lost
                self._send(replies)
                self.transport.close()
                return
            end = 6 + length
            if len(buf) < end:
                break
            pdu = bytes(buf[7:end])
            del buf[:end]
            framed = True
            if pid != 0:
                continue                         # not Modbus: dropped, unanswered
            reply = self.server.answer(pdu)
            replies.append(MBAP.pack(tid, 0, len(reply) + 1, unit) + reply)
        self._send(replies)
        if not buf:
            self._stop_timer()
        elif framed or self.timer is None:       # a new frame began: its own time
            self._stop_timer()
            self.timer = asyncio.get_running_loop().call_later(FRAME_TIMEOUT_S, self._expired)

    def _send(self, replies: list[bytes]) -> None:
        if replies and self.transport is not None:
            self.transport.write(b''.join(replies))

    def _expired(self) -> None:
        self.timer = None
        if self.transport is not None:
            self.transport.close()

    def _stop_timer(self) -> None:
        if self.timer is not None:
            self.timer.cancel()
            self.timer = None
