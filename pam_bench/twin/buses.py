"""The simulated bench behind real protocols: a Modbus TCP DAQ and a CiA 402 drive on CAN.

``EmulatedBench`` steps a bench of the twin (the single-muscle ``twin.bench.SingleMuscleBench``
or the torque servo's pair, ``twin.pair_bench.PairBench``: the physics the device nodes run,
tested against them) on the wall clock at ``rate_hz`` and serves it as a lab's hardware would
be:

- a **Modbus TCP server** on 127.0.0.1 (``twin.modbus_server``: the exceptions and access
  rules of the Modbus Application Protocol and of the device's map) with the registers of a
  register map (``buses.register_map``): the measured forces, pulley angle and absolute valve
  pressures in its input registers, refreshed every tick (a signal the bench lacks reads as
  no force, atmospheric pressure); each valve voltage read from its holding registers every
  tick (a value the map refuses vents that valve); with no write for
  the map's ``watchdog_s`` the DAQ's own watchdog sets its outputs to 0 V, as remote I/O
  couplers do when their master goes quiet, and a device without one (a LabJack T7's TDAC)
  keeps its output where it was;
- a **CiA 402 drive** (the loading servo) on a CAN bus, as CiA 301 and 402 say a standard
  master sees one (``twin.cia402_drive``: NMT, SDO, PDO rules and transmission types, EMCY
  and the error history, modes 8 and 10).

Faults, for the tests of the drivers: ``stop_modbus`` (the server goes away; back with
``restart_modbus``), ``emcy`` (the
drive faults and sends an EMCY), ``silence_can`` (heartbeat and PDOs stop; ``talk_can``
ends it), ``corrupt``
(a register holds an out-of-range value for a while).
"""

from __future__ import annotations

import math
import struct
import threading
import time
from typing import Any, Protocol

from pam_bench.buses.cia402 import (
    DriveScale,
    State,
)
from pam_bench.buses.register_map import RegisterMap
from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.twin.cia402_drive import EmulatedDrive

__all__ = ['EmulatedBench', 'ServedBench']


class ServedBench(Protocol):
    """What the buses serve: a bench of the twin with its drive (``servo``: ``phi`` rad,
    ``torque`` N m)."""

    servo: Any

    def command_valve(self, voltage_v: float, channel: int = 1) -> None:
        """Hold a valve's voltage, V."""

    def command_load(self, mode: Any, setpoint: float, now: bool = False) -> None:
        """The drive's mode and set value."""

    def step(self, h_s: float) -> Any:
        """One exchange of ``h_s`` s."""

    def signals(self) -> dict[str, float]:
        """The measured signals by register-map name (gauge Pa, N, rad)."""

MAX_STEP_S = 0.005
"""Longest step the bench takes at once after the loop was late (a longer lag is dropped:
the bench's own clock does not stop, but the physics is stepped in pieces it can take)."""



class EmulatedBench:
    """The bench served behind Modbus TCP and CANopen (module docstring).

    Args:
        bench: the simulated bench (valve, muscle, sensors, drive).
        register_map: the DAQ's registers.
        modbus_port: TCP port on 127.0.0.1 of the Modbus server.
        can: python-can keywords of the drive's bus (``buses.can_hub.bus_config``).
        node_id: the drive's CANopen node id.
        scale: the drive's units (``buses.cia402.DriveScale``).
        rate_hz: the bench's tick rate on the wall clock.
    """

    def __init__(self, bench: ServedBench, register_map: RegisterMap, modbus_port: int,
                 can: dict[str, Any], node_id: int = 5, scale: DriveScale | None = None,
                 rate_hz: float = 1000.0) -> None:
        self.bench = bench
        self.map = register_map
        self.port = modbus_port
        self.can = can
        self.node_id = node_id
        self.scale = scale or DriveScale()
        self.period_s = 1.0 / rate_hz
        self.words: dict[tuple[str, int], int] = {}   # (register, address) -> value
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._server: Any = None
        self._corrupt: dict[str, tuple[list[int], float]] = {}
        self.ticks = 0
        self.drive = EmulatedDrive(bench, self._lock, can, node_id, self.scale)
        self.voltages_v: dict[str, float] = {c.signal: 0.0 for c in register_map.outputs}
        self.watchdog_s = register_map.watchdog_s    # the device's own (0: it has none)
        self._written: float | None = None      # last write of the holding registers

    # --- life ---------------------------------------------------------------------------
    def start(self) -> EmulatedBench:
        """Serve Modbus and CANopen, then tick the bench; returns self.

        Raises:
            BusUnreachable: the Modbus port or the CAN bus cannot be used (one line).
        """
        self._publish_inputs()
        self._start_modbus()
        self._start_can()
        t = threading.Thread(target=self._run, daemon=True, name='bench-ticks')
        t.start()
        self._threads.append(t)
        return self

    def stop(self) -> None:
        """Stop ticking, close the server and leave the bus."""
        self._stop.set()
        self.stop_modbus()
        for t in self._threads:
            t.join(timeout=2.0)
        self.drive.stop()

    # --- Modbus ---------------------------------------------------------------------------
    def _start_modbus(self) -> None:
        from pam_bench.twin.modbus_server import ModbusServer
        self._server = ModbusServer(self.map, self.port, self._read_words,
                                    self._write_words).start()

    def _read_words(self, kind: str, start: int, qty: int) -> list[int]:
        """The words a master reads from ``start`` on, all of one tick (in a unified space
        either kind; a register of the device the map does not use reads 0)."""
        words = self.words
        with self._lock:
            if self.map.address_space == 'unified':
                got = [words.get(('input', a), words.get(('holding', a)))
                       for a in range(start, start + qty)]
            else:
                got = [words.get((kind, a)) for a in range(start, start + qty)]
        return [0 if w is None else w for w in got]

    def _write_words(self, address: int, words: list[int]) -> None:
        """Holding registers written by the master, kept for the next tick."""
        with self._lock:
            for k, v in enumerate(words):
                self.words[('holding', address + k)] = int(v)
            self._written = time.monotonic()

    def restart_modbus(self) -> None:
        """The Modbus server comes back on the same port (after ``stop_modbus``)."""
        if self._server is None:
            self._start_modbus()

    def stop_modbus(self) -> None:
        """The Modbus server goes away (a fault: the DAQ is unplugged)."""
        if self._server is not None:
            self._server.stop()
            self._server = None

    def corrupt(self, signal: str, value: float, duration_s: float) -> None:
        """For ``duration_s``, the registers of ``signal`` hold the raw ``value`` (as a broken
        sensor wire or a flipped register would)."""
        from pam_bench.buses.register_map import TYPES
        c = self.map.channel(signal)
        if c is None:
            raise KeyError(signal)
        code, _ = TYPES[c.type]
        raw = value if c.type == 'float32' else int(value)
        data = struct.pack(f'>{code}', raw)
        words = [int.from_bytes(data[2 * k:2 * k + 2], 'big') for k in range(c.count)]
        self._corrupt[signal] = (words if self.map.word_order == 'big' else words[::-1],
                                 time.monotonic() + duration_s)

    # --- CANopen ---------------------------------------------------------------------------
    def _start_can(self) -> None:
        self.drive.start()

    @property
    def state(self) -> State:
        """The drive's CiA 402 power state."""
        return self.drive.state

    @property
    def mode(self) -> int:
        """The drive's mode of operation."""
        return self.drive.mode

    def emcy(self, code: int = 0x2310) -> None:
        """The drive faults (default: over-current) and says so by EMCY."""
        self.drive.emcy(code)

    def silence_can(self) -> None:
        """The drive stops talking: no heartbeat, no PDO (a cut cable, a dead node)."""
        self.drive.silence()

    def talk_can(self) -> None:
        """The drive talks again after ``silence_can`` (the cable plugged back)."""
        self.drive.talk()

    # --- the bench ------------------------------------------------------------------------
    def _publish_inputs(self) -> None:
        """The bench's measured signals into the input registers (corrupted ones as told)."""
        values = self.bench.signals()
        now = time.monotonic()
        words: dict[tuple[str, int], int] = {}
        for c in self.map.inputs:
            bad = self._corrupt.get(c.signal)
            if bad is not None and now < bad[1]:
                ws = bad[0]
            else:
                v = values.get(c.signal, 0.0)
                if c.signal.endswith('.pressure'):
                    v += ATMOSPHERE_PA                 # the transducer reads absolute
                ws = self.map.encode(c, min(max(v, c.low), c.high))
            for k, w in enumerate(ws):
                words[(c.register, c.address + k)] = w
        with self._lock:
            self.words.update(words)

    @property
    def valve_voltage_v(self) -> float:
        """Valve 1's voltage as the DAQ drives it now, V."""
        return self.voltages_v.get('valve_1.voltage', 0.0)

    def _read_outputs(self) -> None:
        """Each valve's voltage from its holding registers (the watchdog's 0 V after a quiet
        master, when the device has one)."""
        written = self._written
        quiet = bool(self.watchdog_s and written is not None and
                     time.monotonic() - written > self.watchdog_s)
        for c in self.map.outputs:
            with self._lock:
                if quiet:        # the DAQ's own watchdog: no write for a while, outputs safe
                    for k in range(c.count):
                        self.words[('holding', c.address + k)] = 0
                ws = [self.words.get(('holding', c.address + k), 0) for k in range(c.count)]
            u = self.map.decode(c, ws)
            if not math.isfinite(u):
                u = 0.0                               # a command the map refuses: vent
            self.voltages_v[c.signal] = u
            self.bench.command_valve(u, int(c.signal.split('.')[0].rpartition('_')[2]))

    def _run(self) -> None:
        """Tick the bench on the wall clock: outputs in, one step, inputs and TPDO out."""
        last = time.monotonic()
        next_t = last + self.period_s
        while not self._stop.is_set():
            now = time.monotonic()
            if now < next_t:
                time.sleep(min(next_t - now, self.period_s))
                continue
            dt = min(now - last, MAX_STEP_S)
            last = now
            next_t += self.period_s
            if next_t < now - 0.1:
                next_t = now + self.period_s        # a long stall: start again from now
            self._read_outputs()
            with self._lock:
                self.bench.step(dt)
            self._publish_inputs()
            self.drive.tick(now)
            self.ticks += 1
