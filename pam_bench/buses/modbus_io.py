"""The DAQ driver's side of Modbus TCP: the outputs written and the inputs read in one round
trip per tick, through a register map, with each round trip timed.

``ModbusIo`` is a small Modbus TCP master on a plain socket (MODBUS Messaging on TCP/IP
Implementation Guide V1.0b, "MODBUS TCP/IP ADU"): function 16 (write multiple registers) for
each output block, then function 4 or 3 (read input / holding registers) for each input block,
all sent at once and answered in order; each reply is matched to its request by the MBAP
transaction identifier and checked for its function code, byte count and quantity. The guide
lets a client keep several transactions open on one connection ("Client design", 4.3.1.2); a
server that serves one at a time answers them from its TCP buffer in turn. Sending them
together makes an exchange one round trip instead of one per block, and skips a general
client's framer (the two against pymodbus' synchronous client: BENCHMARKS.md, "The bench
behind real buses").

A request that times out, a connection that drops, an exception response or a reply that does
not match its request raises ``BusUnreachable``; the caller (``nodes.daq_modbus``) then puts its
outputs in the safe state, says so, closes the connection (so no late reply is ever read as
the answer to a later request) and calls ``connect`` again with a back-off (``Backoff``).
"""

from __future__ import annotations

import contextlib
import math
import socket
import struct
import time

from pam_bench.buses.errors import BusUnreachable
from pam_bench.buses.register_map import Block, RegisterMap

MBAP = struct.Struct('>HHHB')
"""The MBAP header: transaction, protocol, length (unit and PDU), unit (the master's and the
emulated server's one layout)."""

__all__ = ['ModbusIo', 'Backoff', 'MBAP']


class Backoff:
    """Reconnection delays: ``first_s``, doubled after each failure up to ``max_s``; reset
    after a success."""

    def __init__(self, first_s: float = 0.1, max_s: float = 2.0) -> None:
        self.first_s, self.max_s = first_s, max_s
        self.delay_s = first_s
        self.next_t = 0.0

    def due(self, now: float) -> bool:
        """Whether a new attempt is due at ``now`` (monotonic s)."""
        return now >= self.next_t

    def failed(self, now: float) -> None:
        """An attempt failed at ``now``: wait, then wait longer next time."""
        self.next_t = now + self.delay_s
        self.delay_s = min(self.delay_s * 2.0, self.max_s)

    def reset(self) -> None:
        """An attempt succeeded."""
        self.delay_s, self.next_t = self.first_s, 0.0


class ModbusIo:
    """A register map read and written over Modbus TCP (module docstring).

    Args:
        register_map: what the registers carry.
        host, port: the server (a DAQ, or the emulated bench on 127.0.0.1).
        timeout_s: how long a reply may take before the connection counts as lost.
    """

    def __init__(self, register_map: RegisterMap, host: str, port: int,
                 timeout_s: float = 0.05) -> None:
        self.map = register_map
        self.host, self.port, self.timeout_s = host, port, timeout_s
        self.sock: socket.socket | None = None
        self.in_blocks = register_map.blocks(False)
        self.out_blocks = register_map.blocks(True)
        self.round_trips_s: list[float] = []     # one per exchange since the last take
        self._tid = 0
        self._buffer = bytearray()               # reply bytes received, not yet cut

    def _where(self) -> str:
        return f'Modbus server {self.host}:{self.port}'

    def connect(self) -> None:
        """Open the connection.

        Raises:
            BusUnreachable: no server answers at host:port.
        """
        self.close()
        try:
            sock = socket.create_connection((self.host, self.port), timeout=self.timeout_s)
        except OSError as exc:
            raise BusUnreachable(f'{self._where()}: {exc}') from None
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock = sock

    def close(self) -> None:
        """Close the connection."""
        self._buffer.clear()
        if self.sock is not None:
            with contextlib.suppress(OSError):
                self.sock.close()
            self.sock = None

    # --- frames ------------------------------------------------------------------------
    def _frame(self, pdu: bytes) -> tuple[int, bytes]:
        self._tid = (self._tid + 1) & 0xFFFF
        return self._tid, struct.pack('>HHHB', self._tid, 0, len(pdu) + 1,
                                      self.map.device_id) + pdu

    def _write_pdu(self, b: Block, values: dict[str, float]) -> bytes:
        words: list[int] = []
        for c in b.channels:
            v = values.get(c.signal, 0.0)
            try:
                words += self.map.encode(c, v if math.isfinite(v) else 0.0)
            except ValueError:
                words += self.map.encode(c, 0.0)
        return struct.pack(f'>BHHB{len(words)}H', 16, b.address, len(words), 2 * len(words),
                           *words)

    @staticmethod
    def _read_pdu(b: Block) -> bytes:
        return struct.pack('>BHH', 4 if b.register == 'input' else 3, b.address, b.count)

    def _replies(self, n: int) -> list[tuple[int, int, bytes]]:
        """The next ``n`` reply frames as (transaction, protocol, PDU), read in as few
        receives as they arrive in (a server that answers a batch in one segment: one)."""
        assert self.sock is not None
        buf = self._buffer
        out: list[tuple[int, int, bytes]] = []
        while True:
            while len(out) < n and len(buf) >= 7:
                tid, pid, length, _unit = MBAP.unpack_from(buf)
                if not 2 <= length <= 254:
                    raise OSError(f'reply out of step (transaction {tid}, protocol {pid}, '
                                  f'length {length})')
                if len(buf) < 6 + length:
                    break
                out.append((tid, pid, bytes(buf[7:6 + length])))
                del buf[:6 + length]
            if len(out) == n:
                return out
            chunk = self.sock.recv(4096)
            if not chunk:
                raise OSError('connection closed by the server')
            buf += chunk

    def _transact(self, pdus: list[bytes]) -> list[bytes]:
        """Send every request at once; the reply PDUs in the same order (module docstring)."""
        if self.sock is None:
            raise BusUnreachable(f'{self._where()}: not connected')
        framed = [self._frame(p) for p in pdus]
        t0 = time.perf_counter()
        try:
            self.sock.sendall(b''.join(f for _, f in framed))
            replies = []
            for (tid, _), (r_tid, pid, pdu) in zip(framed, self._replies(len(framed)),
                                                   strict=True):
                if r_tid != tid or pid != 0:
                    raise OSError(f'reply out of step (transaction {r_tid}, protocol {pid}; '
                                  f'expected transaction {tid})')
                replies.append(pdu)
        except OSError as exc:       # timeouts, resets, frames out of step
            raise BusUnreachable(f'{self._where()}: {exc or type(exc).__name__}') from None
        self.round_trips_s.append(time.perf_counter() - t0)
        for req, rep in zip(pdus, replies, strict=True):
            if rep[0] == req[0] | 0x80 and len(rep) == 2:
                raise BusUnreachable(f'{self._where()}: exception {rep[1]:#04x} to function '
                                     f'{req[0]}')
            if rep[0] != req[0] or (req[0] == 16 and rep != req[:5]):
                raise BusUnreachable(f'{self._where()}: reply {rep[:5].hex()} does not answer '
                                     f'request {req[:5].hex()}')
        return replies

    def _decode(self, pdus: list[bytes]) -> dict[str, float]:
        out: dict[str, float] = {}
        for b, rep in zip(self.in_blocks, pdus, strict=True):
            if len(rep) != 2 + 2 * b.count or rep[1] != 2 * b.count:
                raise BusUnreachable(f'{self._where()}: {len(rep) - 2} bytes for '
                                     f'{b.count} registers at {b.address}')
            out.update(self.map.decode_block(b, list(struct.unpack(f'>{b.count}H', rep[2:]))))
        return out

    # --- what the driver calls -----------------------------------------------------------
    def exchange(self, values: dict[str, float]) -> dict[str, float]:
        """Write every output signal and read every input signal, in one round trip.

        Args:
            values: signal -> SI value to write (one missing or refused by the map is written
                as its safe value, 0).

        Returns:
            Every input signal, SI (NaN: a value the map refuses, to reject).

        Raises:
            BusUnreachable: a request failed, timed out or was answered out of step.
        """
        writes = [self._write_pdu(b, values) for b in self.out_blocks]
        replies = self._transact(writes + [self._read_pdu(b) for b in self.in_blocks])
        return self._decode(replies[len(writes):])

    def read_inputs(self) -> dict[str, float]:
        """Every input signal, SI (NaN: a value the map refuses, to reject).

        Raises:
            BusUnreachable: a request failed or timed out.
        """
        return self._decode(self._transact([self._read_pdu(b) for b in self.in_blocks]))

    def write_outputs(self, values: dict[str, float]) -> None:
        """Write every output signal (``values``: signal -> SI; one missing or refused by the
        map is written as its safe value, 0).

        Raises:
            BusUnreachable: a request failed or timed out.
        """
        self._transact([self._write_pdu(b, values) for b in self.out_blocks])

    def take_round_trips(self) -> list[float]:
        """The round trips (s) of the exchanges since the last call."""
        out, self.round_trips_s = self.round_trips_s, []
        return out
