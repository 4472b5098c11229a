"""The DAQ driver's side of Modbus TCP: one read of the inputs and one write of the outputs per
tick, through a register map, with the round trip of each request timed.

``ModbusIo`` wraps pymodbus' synchronous TCP client. A request that times out or a connection
that drops raises ``BusUnreachable``; the caller (``nodes.daq_modbus``) then puts its outputs
in the safe state, says so, and calls ``reconnect`` with a back-off (``Backoff``).
"""

from __future__ import annotations

import contextlib
import math
import time
from typing import Any

from pam_bench.buses.errors import BusUnreachable
from pam_bench.buses.register_map import RegisterMap

__all__ = ['ModbusIo', 'Backoff']


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
        timeout_s: how long a request may take before the connection counts as lost.
    """

    def __init__(self, register_map: RegisterMap, host: str, port: int,
                 timeout_s: float = 0.05) -> None:
        from pymodbus.client import ModbusTcpClient
        self.map = register_map
        self.host, self.port = host, port
        self.client = ModbusTcpClient(host, port=port, timeout=timeout_s, retries=0,
                                      reconnect_delay=0.0)
        self.in_blocks = register_map.blocks(False)
        self.out_blocks = register_map.blocks(True)
        self.round_trips_s: list[float] = []     # one per request since the last take

    def connect(self) -> None:
        """Open the connection.

        Raises:
            BusUnreachable: no server answers at host:port.
        """
        try:
            ok = self.client.connect()
        except Exception as exc:  # noqa: BLE001 - pymodbus raises several types
            raise BusUnreachable(f'Modbus server {self.host}:{self.port}: {exc}') from None
        if not ok:
            raise BusUnreachable(f'Modbus server {self.host}:{self.port}: connection refused '
                                 'or timed out')

    def close(self) -> None:
        """Close the connection."""
        with contextlib.suppress(Exception):
            self.client.close()

    def _request(self, call: Any, *args: Any, **kw: Any) -> Any:
        t0 = time.perf_counter()
        try:
            rr = call(*args, device_id=self.map.device_id, **kw)
        except Exception as exc:  # noqa: BLE001 - timeouts, resets, protocol errors
            raise BusUnreachable(f'Modbus server {self.host}:{self.port}: {exc}') from None
        self.round_trips_s.append(time.perf_counter() - t0)
        if rr.isError():
            raise BusUnreachable(f'Modbus server {self.host}:{self.port}: {rr}')
        return rr

    def read_inputs(self) -> dict[str, float]:
        """Every input signal, SI (NaN: a value the map refuses, to reject).

        Raises:
            BusUnreachable: a request failed or timed out.
        """
        out: dict[str, float] = {}
        for b in self.in_blocks:
            call = (self.client.read_input_registers if b.register == 'input'
                    else self.client.read_holding_registers)
            rr = self._request(call, b.address, count=b.count)
            out.update(self.map.decode_block(b, list(rr.registers)))
        return out

    def write_outputs(self, values: dict[str, float]) -> None:
        """Write every output signal (``values``: signal -> SI; one missing or refused by the
        map is written as its safe value, 0).

        Raises:
            BusUnreachable: a request failed or timed out.
        """
        for b in self.out_blocks:
            words: list[int] = []
            for c in b.channels:
                v = values.get(c.signal, 0.0)
                try:
                    words += self.map.encode(c, v if math.isfinite(v) else 0.0)
                except ValueError:
                    words += self.map.encode(c, 0.0)
            self._request(self.client.write_registers, b.address, words)

    def take_round_trips(self) -> list[float]:
        """The round trips (s) of the requests since the last call."""
        out, self.round_trips_s = self.round_trips_s, []
        return out
