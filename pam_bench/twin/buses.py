"""The simulated bench behind real protocols: a Modbus TCP DAQ and a CiA 402 drive on CAN.

``EmulatedBench`` steps the single-muscle bench of the twin (``twin.bench.SingleMuscleBench``,
the physics the device nodes run, tested against them) on the wall clock at ``rate_hz`` and
serves it as a lab's hardware would be:

- a **Modbus TCP server** on 127.0.0.1 (``twin.modbus_server``: the exceptions and access
  rules of the Modbus Application Protocol and of the device's map) with the registers of a
  register map (``buses.register_map``): the measured force, pulley angle and absolute valve
  pressure in its input registers, refreshed every tick; the valve voltage read from its
  holding registers every tick (a value the map refuses vents the valve); with no write for
  the map's ``watchdog_s`` the DAQ's own watchdog sets its outputs to 0 V, as remote I/O
  couplers do when their master goes quiet, and a device without one (a LabJack T7's TDAC)
  keeps its output where it was;
- a **CiA 402 drive** (the loading servo) on a CAN bus (``canopen`` local node with the EDS
  shipped in config/buses/loading_servo.eds): NMT, an SDO server, a heartbeat every
  0x1017 ms, RPDO 1 (controlword, target torque, target position) and TPDO 1 (statusword,
  torque actual, position actual, sent in answer to each RPDO: the cycle is the master's, as
  with a SYNC) as their mapping objects say (the driver writes them by SDO), the power
  state machine of ``buses.cia402``, modes 8 (position) and 10 (torque) through 0x6060.
  Only in operation enabled does the drive pull: a target torque
  T (per mille of rated) becomes the bench's force set value F = T i / r, a target position
  its contraction set value r theta; every other state turns the drive off.

Faults, for the tests of the drivers: ``stop_modbus`` (the server goes away; back with
``restart_modbus``), ``emcy`` (the
drive faults and sends an EMCY), ``silence_can`` (heartbeat and PDOs stop; ``talk_can``
ends it), ``corrupt``
(a register holds an out-of-range value for a while).
"""

from __future__ import annotations

import contextlib
import math
import struct
import threading
import time
from typing import Any

from pam_bench.buses.canopen_drive import eds_path, open_network
from pam_bench.buses.cia402 import (
    MODE_CSP,
    MODE_CST,
    OD,
    STATUSWORD,
    DriveScale,
    State,
    next_state,
)
from pam_bench.buses.register_map import RegisterMap
from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.models.loading_servo import LoadMode
from pam_bench.twin.bench import SingleMuscleBench

__all__ = ['EmulatedBench']

MAX_STEP_S = 0.005
"""Longest step the bench takes at once after the loop was late (a longer lag is dropped:
the bench's own clock does not stop, but the physics is stepped in pieces it can take)."""


_FORMATS = {0x0002: 'b', 0x0003: 'h', 0x0004: 'i', 0x0005: 'B', 0x0006: 'H', 0x0007: 'I'}
"""CANopen data type -> struct code (the integer types a PDO of the bench maps)."""


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

    def __init__(self, bench: SingleMuscleBench, register_map: RegisterMap, modbus_port: int,
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
        self.state = State.SWITCH_ON_DISABLED
        self.mode = 0
        self._cw = 0
        self._targets = (0, 0)                  # (torque per mille, position counts)
        self._applied: tuple[LoadMode, float] | None = None
        self._silent = False
        self.ticks = 0
        self.network: Any = None
        self.node: Any = None
        self._rpdo: list[tuple[int, str]] = []
        self._tpdo: list[tuple[int, str]] = []
        self._tpdo_cob = 0x180 + node_id
        self.valve_voltage_v = 0.0
        self.rejected_outputs = 0
        self.watchdog_s = register_map.watchdog_s    # the device's own (0: it has none)
        self._written: float | None = None      # last write of the holding registers
        self.watchdog_trips = 0

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
        if self.network is not None:
            with contextlib.suppress(Exception):
                self.node.nmt.stop_heartbeat()
            with contextlib.suppress(Exception):
                self.network.disconnect()

    # --- Modbus ---------------------------------------------------------------------------
    def _start_modbus(self) -> None:
        from pam_bench.twin.modbus_server import ModbusServer
        self._server = ModbusServer(self.map, self.port, self._read_word,
                                    self._write_words).start()

    def _read_word(self, kind: str, address: int) -> int:
        """The word a master reads at ``address`` (in a unified space either kind; a register
        of the device the map does not use reads 0)."""
        with self._lock:
            if self.map.address_space == 'unified':
                w = self.words.get(('input', address), self.words.get(('holding', address)))
            else:
                w = self.words.get((kind, address))
        return 0 if w is None else w

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

    # --- CANopen --------------------------------------------------------------------------
    def _start_can(self) -> None:
        import canopen
        self.network = open_network(self.can)
        self.node = canopen.LocalNode(self.node_id, eds_path())
        self.network.add_node(self.node)
        self.node.add_write_callback(self._on_write)
        self.node.add_read_callback(self._on_read)
        self.network.subscribe(0, self._on_nmt)
        self.node.nmt.state = 'PRE-OPERATIONAL'
        self.network.send_message(0x700 + self.node_id, [0])          # boot-up
        period = self.node.get_data(0x1017, 0)
        self._heartbeat_ms = int.from_bytes(period, 'little')
        if self._heartbeat_ms:
            self.node.nmt.start_heartbeat(self._heartbeat_ms)

    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        """NMT start: take the PDO mapping the master wrote (by SDO) and subscribe RPDO 1."""
        if len(data) >= 2 and data[0] == 0x01 and data[1] in (0, self.node_id):
            self._map_pdos()

    def _mapping(self, index: int) -> list[tuple[int, str]]:
        """(od index, struct code) of each object a PDO mapping object lists."""
        n = self.node.get_data(index, 0)[0]
        out = []
        for sub in range(1, n + 1):
            entry = int.from_bytes(self.node.get_data(index, sub), 'little')
            od = entry >> 16
            out.append((od, _FORMATS[self.node.object_dictionary[od].data_type]))
        return out

    def _map_pdos(self) -> None:
        rx_cob = int.from_bytes(self.node.get_data(0x1400, 1), 'little') & 0x7FF
        self._tpdo_cob = int.from_bytes(self.node.get_data(0x1800, 1), 'little') & 0x7FF
        self._rpdo, self._tpdo = self._mapping(0x1600), self._mapping(0x1A00)
        with contextlib.suppress(Exception):
            self.network.unsubscribe(rx_cob, self._on_rpdo)
        self.network.subscribe(rx_cob, self._on_rpdo)

    def _on_write(self, index: int, subindex: int, od: Any, data: bytes) -> None:
        if index == OD['modes_of_operation']:
            self.mode = struct.unpack('<b', bytes(data))[0]
            self._apply()
        elif index == OD['controlword']:
            self._controlword(int.from_bytes(data, 'little'))

    def _on_read(self, index: int, subindex: int, od: Any) -> int | None:
        if index == OD['statusword']:
            return STATUSWORD[self.state]
        if index == OD['modes_display']:
            return self.mode
        return None

    def _on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if self._silent or self.node.nmt.state != 'OPERATIONAL':
            return
        fmt = '<' + ''.join(code for _, code in self._rpdo)
        if struct.calcsize(fmt) != len(data):
            return
        values = dict(zip((od for od, _ in self._rpdo), struct.unpack(fmt, bytes(data)),
                          strict=True))
        self._targets = (values.get(OD['target_torque'], self._targets[0]),
                         values.get(OD['target_position'], self._targets[1]))
        if OD['modes_of_operation'] in values:
            self.mode = values[OD['modes_of_operation']]
        self._controlword(values.get(OD['controlword'], self._cw))
        self._send_tpdo()             # one TPDO per RPDO: the cycle the master sets

    def _controlword(self, cw: int) -> None:
        self.state, self._cw = next_state(self.state, cw, self._cw), cw
        self._apply()

    def _apply(self) -> None:
        """What the drive does in its state and mode (module docstring)."""
        if self.state == State.OPERATION_ENABLED and self.mode == MODE_CST:
            wanted = (LoadMode.FORCE, self.scale.force_of_permille(self._targets[0]))
        elif self.state == State.OPERATION_ENABLED and self.mode == MODE_CSP:
            wanted = (LoadMode.POSITION,
                      self.scale.angle_of(self._targets[1]) * self.scale.radius_m)
        else:
            wanted = (LoadMode.OFF, 0.0)
        if wanted != self._applied:
            self._applied = wanted
            with self._lock:
                self.bench.command_load(*wanted)

    def emcy(self, code: int = 0x2310) -> None:
        """The drive faults (default: over-current) and says so by EMCY."""
        self.state = State.FAULT
        self._apply()
        self.node.emcy.send(code, 0x02)

    def silence_can(self) -> None:
        """The drive stops talking: no heartbeat, no PDO (a cut cable, a dead node)."""
        self._silent = True
        with contextlib.suppress(Exception):
            self.node.nmt.stop_heartbeat()

    def talk_can(self) -> None:
        """The drive talks again after ``silence_can`` (the cable plugged back): heartbeat
        and PDOs resume, in whatever power state the master's last controlword left."""
        self._silent = False
        if self._heartbeat_ms:
            with contextlib.suppress(Exception):
                self.node.nmt.start_heartbeat(self._heartbeat_ms)

    def _send_tpdo(self) -> None:
        if self._silent or not self._tpdo or self.node.nmt.state != 'OPERATIONAL':
            return
        servo, s = self.bench.servo, self.scale
        values = {OD['statusword']: STATUSWORD[self.state], OD['modes_display']: self.mode,
                  OD['position_actual']: s.counts(servo.phi),
                  OD['torque_actual']: max(-32768, min(32767, round(
                      1000.0 * servo.torque / s.gear_ratio / s.rated_torque_nm)))}
        fmt = '<' + ''.join(code for _, code in self._tpdo)
        data = struct.pack(fmt, *(values[od] for od, _ in self._tpdo))
        with contextlib.suppress(Exception):
            self.network.send_message(self._tpdo_cob, data)

    # --- the bench ------------------------------------------------------------------------
    def _publish_inputs(self) -> None:
        """The bench's measured signals into the input registers (corrupted ones as told)."""
        b = self.bench
        values = {'valve_1.pressure': b.p + ATMOSPHERE_PA, 'load_cell_1.force': b.f_meas,
                  'encoder.angle': b.th_meas, 'valve_2.pressure': ATMOSPHERE_PA,
                  'load_cell_2.force': 0.0}
        now = time.monotonic()
        words: dict[tuple[str, int], int] = {}
        for c in self.map.inputs:
            bad = self._corrupt.get(c.signal)
            if bad is not None and now < bad[1]:
                ws = bad[0]
            else:
                v = values[c.signal]
                ws = self.map.encode(c, min(max(v, c.low), c.high))
            for k, w in enumerate(ws):
                words[(c.register, c.address + k)] = w
        with self._lock:
            self.words.update(words)

    def _read_outputs(self) -> None:
        c = self.map.channel('valve_1.voltage')
        if c is None:
            return
        with self._lock:
            ws = [self.words.get(('holding', c.address + k), 0) for k in range(c.count)]
        u = self.map.decode(c, ws)
        if not math.isfinite(u):
            self.rejected_outputs += 1
            u = 0.0                                   # a command the map refuses: vent
        written = self._written
        if self.watchdog_s and written is not None and \
                time.monotonic() - written > self.watchdog_s:
            if u != 0.0 or self.valve_voltage_v != 0.0:
                self.watchdog_trips += 1
            u = 0.0               # the DAQ's own watchdog: no write for a while, outputs safe
            with self._lock:
                for k in range(c.count):
                    self.words[('holding', c.address + k)] = 0
        self.valve_voltage_v = u
        self.bench.command_valve(u)

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
            self.ticks += 1
