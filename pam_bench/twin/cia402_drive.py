"""The loading servo's drive as a CiA 301 / CiA 402 device on CAN, as a standard master sees it.

``EmulatedDrive`` is a ``canopen`` local node with the EDS shipped in
config/buses/loading_servo.eds, over the simulated bench's drive (``twin.bench``):

* **NMT** (CiA 301): boot-up message and pre-operational after power-on and after each reset;
  reset node restores every object to its default, reset communication the communication
  objects (0x1000..0x1FFF); in stopped no SDO and no PDO is served; a heartbeat every 0x1017 ms.
* **SDO**: every object reads what the drive holds: the statusword, the actual position and
  torque, the targets (written by SDO or by PDO alike), the mode and its display.
* **PDO** rules: a mapping is changed only with its PDO invalid (COB-ID bit 31) and its count
  (sub-index 0) at 0, each entry an existing mappable object of its length, at most 64 bits in
  all; a valid PDO's COB-ID is not moved; the transmission type is 0..240, 254 or 255. Each
  rule broken is the abort code CiA 301 gives (0x06040043 general parameter incompatibility,
  0x06040041 object cannot be mapped, 0x06040042 PDO length exceeded, 0x06090030 value range
  exceeded). TPDO 1 goes out by its transmission type: every n-th SYNC (1..240; 0 at every
  SYNC), or on its event timer and on a change of the statusword (254, 255). An RPDO of a
  synchronous type is taken at the next SYNC, else at once.
* **CiA 402**: the power state machine of ``buses.cia402``; modes 8 (cyclic synchronous
  position) and 10 (cyclic synchronous torque), declared in 0x6502; another mode is refused
  (0x06090030). Statusword bits beyond the state: 4 voltage enabled, 9 remote, 10 target
  reached, 12 drive follows the command value (cyclic modes, operation enabled).
* **EMCY** (CiA 301): a fault sends its code with the error register (0x1001: generic bit,
  and the class of the code), keeps it in 0x603F and at the head of the error history
  (0x1003); the fault reset sends the error-reset EMCY (code 0) and clears both.

Only in operation enabled does the drive pull: a target torque T (per mille of the rated)
becomes the bench's force set value F = T i / r, a target position its contraction set value
r theta; any other state turns the drive off.
"""

from __future__ import annotations

import contextlib
import struct
import threading
from typing import Any

from pam_bench.buses.canopen_drive import eds_path, open_network
from pam_bench.buses.cia402 import MODE_CSP, MODE_CST, OD, STATUSWORD, DriveScale, State
from pam_bench.buses.cia402 import next_state as next_402
from pam_bench.models.loading_servo import LoadMode

__all__ = ['EmulatedDrive', 'SUPPORTED_MODES', 'ABORT']

SUPPORTED_MODES = {MODE_CSP: 0x0080, MODE_CST: 0x0200}
"""The modes the drive runs -> their bit of 0x6502 (CiA 402)."""
ABORT = {'incompatible': 0x06040043, 'not mappable': 0x06040041, 'too long': 0x06040042,
         'range': 0x06090030}
"""CiA 301 SDO abort codes the PDO and mode rules answer with."""
_FORMATS = {0x0002: 'b', 0x0003: 'h', 0x0004: 'i', 0x0005: 'B', 0x0006: 'H', 0x0007: 'I'}
"""CANopen data type -> struct code (the integer types a PDO of the drive maps)."""
_ERROR_CLASS = {0x2: 0x02, 0x3: 0x04, 0x4: 0x08, 0x8: 0x10}
"""An EMCY code's first digit -> its bit of the error register (current, voltage,
temperature, communication), besides the generic bit 0."""
HISTORY = 4
"""Entries the error history (0x1003) keeps."""


class EmulatedDrive:
    """The drive (module docstring) over ``bench``'s loading servo, ``lock`` held while the
    bench is touched.

    Args:
        bench: the simulated bench (``command_load``, ``servo``).
        lock: the lock the bench's ticks hold.
        can: python-can keywords of the bus.
        node_id: the drive's node id.
        scale: its units.
    """

    def __init__(self, bench: Any, lock: threading.Lock, can: dict[str, Any], node_id: int,
                 scale: DriveScale) -> None:
        self.bench, self.lock, self.can = bench, lock, can
        self.node_id, self.scale = node_id, scale
        self.network: Any = None
        self.node: Any = None
        self.silent = False
        self._rx_cob = self._tx_cob = 0
        self._rx_valid = self._tx_valid = False
        self._rpdo: list[tuple[int, str]] = []
        self._tpdo: list[tuple[int, str]] = []
        self._reset_state()

    def _reset_state(self) -> None:
        """The drive's own state at power-on (and after a reset node)."""
        self.state = State.SWITCH_ON_DISABLED
        self.mode = 0
        self._cw = 0
        self._targets = [0, 0]                   # [torque per mille, position counts]
        self._applied: tuple[LoadMode, float] | None = None
        self._syncs = 0
        self._pending_rpdo: bytes | None = None
        self._last_tpdo = 0.0
        self._last_sw = -1
        self.errors: list[int] = []              # the error history, newest first
        self.error_code = 0

    # --- life ---------------------------------------------------------------------------
    def start(self) -> None:
        """Join the bus, boot up (pre-operational, heartbeat).

        Raises:
            BusUnreachable: the bus cannot be opened.
        """
        import canopen
        self.network = open_network(self.can)
        self.node = canopen.LocalNode(self.node_id, eds_path())
        self.network.add_node(self.node)
        self.node.add_write_callback(self._on_write)
        self.node.add_read_callback(self._on_read)
        sdo = self.node.sdo
        self.network.unsubscribe(sdo.rx_cobid, sdo.on_request)      # served unless stopped
        self.network.subscribe(sdo.rx_cobid, self._on_sdo)
        self.network.subscribe(0, self._on_nmt)
        self.network.subscribe(0x80, self._on_sync)
        self._boot()

    def stop(self) -> None:
        """Leave the bus."""
        if self.network is None:
            return
        with contextlib.suppress(Exception):
            self.node.nmt.stop_heartbeat()
        with contextlib.suppress(Exception):
            self.network.disconnect()

    def _boot(self) -> None:
        """Boot-up message, then pre-operational with the heartbeat of 0x1017."""
        self.node.nmt.send_command(0x81)          # initialising: the boot-up message
        self.node.nmt.send_command(0x80)          # pre-operational: the heartbeat starts
        self._map_pdos()

    # --- NMT and SDO --------------------------------------------------------------------
    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) < 2 or data[1] not in (0, self.node_id):
            return
        cmd = data[0]
        if cmd == 0x01:
            self._map_pdos()
        elif cmd in (0x81, 0x82):                 # reset node / communication
            if cmd == 0x81:
                self.node.data_store.clear()
                with self.lock:
                    self._reset_state()
                self._apply()
            else:
                for index in [i for i in self.node.data_store if i < 0x2000]:
                    del self.node.data_store[index]
            self._boot()
        elif cmd == 0x02:                         # stopped: PDOs stop with it
            self._pending_rpdo = None

    def _on_sdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if self.silent or self.node.nmt.state == 'STOPPED':
            return                                # CiA 301: no SDO in stopped
        self.node.sdo.on_request(can_id, data, timestamp)

    def _raw(self, index: int, sub: int) -> int:
        """An unsigned integer object as the drive holds it."""
        return int.from_bytes(self.node.get_data(index, sub), 'little')

    def _on_read(self, index: int, subindex: int, od: Any) -> int | None:
        servo, s = self.bench.servo, self.scale
        if index == OD['statusword']:
            return self.statusword()
        if index == OD['modes_display']:
            return self.mode
        if index == OD['modes_of_operation']:
            return self.mode
        if index == OD['position_actual']:
            return s.counts(servo.phi)
        if index == OD['torque_actual']:
            return self._torque_permille()
        if index == OD['target_torque']:
            return self._targets[0]
        if index == OD['target_position']:
            return self._targets[1]
        if index == 0x603F:
            return self.error_code
        if index == 0x1001:
            return self._error_register()
        if index == 0x1003:
            if subindex == 0:
                return len(self.errors)
            return self.errors[subindex - 1] if subindex <= len(self.errors) else 0
        if index == 0x2000:
            return round(s.gear_ratio * 1000)
        return None

    def _on_write(self, index: int, subindex: int, od: Any, data: bytes) -> None:
        from canopen.sdo import SdoAbortedError
        if index == OD['modes_of_operation']:
            mode = struct.unpack('<b', bytes(data))[0]
            if mode not in SUPPORTED_MODES and mode != 0:
                raise SdoAbortedError(ABORT['range'])
            self.mode = mode
            self._apply()
        elif index == OD['controlword']:
            self._controlword(int.from_bytes(data, 'little'))
        elif index == OD['target_torque']:
            self._targets[0] = struct.unpack('<h', bytes(data))[0]
            self._apply()
        elif index == OD['target_position']:
            self._targets[1] = struct.unpack('<i', bytes(data))[0]
            self._apply()
        elif index == 0x1003 and subindex == 0:
            if bytes(data) != b'\x00':                # only 0 may be written: clear it
                raise SdoAbortedError(ABORT['range'])
            self.errors.clear()
        elif index in (0x1400, 0x1800) or index in (0x1600, 0x1A00):
            self._pdo_rule(index, subindex, int.from_bytes(data, 'little'))

    def _pdo_rule(self, index: int, sub: int, value: int) -> None:
        """The PDO rules of CiA 301 (module docstring).

        Raises:
            SdoAbortedError: the write breaks one (its abort code).
        """
        from canopen.sdo import SdoAbortedError
        com = index if index in (0x1400, 0x1800) else index - 0x200
        valid = not self._raw(com, 1) & 0x80000000
        if index == com:
            if sub == 1 and valid and not value & 0x80000000 and \
                    value & 0x7FF != self._raw(com, 1) & 0x7FF:
                raise SdoAbortedError(ABORT['range'])   # a valid PDO's COB-ID stays
            if sub == 2 and 240 < value < 254:
                raise SdoAbortedError(ABORT['range'])   # reserved transmission types
            return
        if valid:
            raise SdoAbortedError(ABORT['incompatible'])    # mapping of a valid PDO
        if sub == 0:
            total = 0
            for k in range(1, value + 1):
                total += self._entry_bits(self._raw(index, k))
            if total > 64:
                raise SdoAbortedError(ABORT['too long'])
            return
        if self._raw(index, 0) != 0:
            raise SdoAbortedError(ABORT['incompatible'])    # entries only at count 0
        self._entry_bits(value)

    def _entry_bits(self, entry: int) -> int:
        """The bits a mapping entry takes, checked (an existing, mappable object of its
        length).

        Raises:
            SdoAbortedError: ``ABORT['not mappable']``.
        """
        from canopen.sdo import SdoAbortedError
        index, sub, bits = entry >> 16, (entry >> 8) & 0xFF, entry & 0xFF
        from canopen.objectdictionary import ODVariable
        od = self.node.object_dictionary
        try:
            obj = od[index]
            if not isinstance(obj, ODVariable):
                obj = obj[sub]
        except KeyError:
            raise SdoAbortedError(ABORT['not mappable']) from None
        if not getattr(obj, 'pdo_mappable', False) or len(obj) != bits:
            raise SdoAbortedError(ABORT['not mappable'])
        return bits

    # --- PDO ------------------------------------------------------------------------------
    def _mapping(self, index: int) -> list[tuple[int, str]]:
        """(od index, struct code) of each object a PDO mapping object lists."""
        out = []
        for sub in range(1, self._raw(index, 0) + 1):
            od = self._raw(index, sub) >> 16
            out.append((od, _FORMATS[self.node.object_dictionary[od].data_type]))
        return out

    def _map_pdos(self) -> None:
        """Take the PDO mapping and COB-IDs the drive holds now."""
        with contextlib.suppress(Exception):
            self.network.unsubscribe(self._rx_cob, self._on_rpdo)
        self._rx_cob = self._raw(0x1400, 1) & 0x7FF
        self._rx_valid = not self._raw(0x1400, 1) & 0x80000000
        self._tx_cob = self._raw(0x1800, 1) & 0x7FF
        self._tx_valid = not self._raw(0x1800, 1) & 0x80000000
        self._rpdo, self._tpdo = self._mapping(0x1600), self._mapping(0x1A00)
        self.network.subscribe(self._rx_cob, self._on_rpdo)

    def _operational(self) -> bool:
        return not self.silent and self.node.nmt.state == 'OPERATIONAL'

    def _on_rpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if not self._operational() or not self._rx_valid:
            return
        if self._raw(0x1400, 2) <= 240:           # synchronous: taken at the next SYNC
            self._pending_rpdo = bytes(data)
        else:
            self._take_rpdo(bytes(data))

    def _take_rpdo(self, data: bytes) -> None:
        fmt = '<' + ''.join(code for _, code in self._rpdo)
        if struct.calcsize(fmt) != len(data):
            return
        values = dict(zip((od for od, _ in self._rpdo), struct.unpack(fmt, data), strict=True))
        if OD['target_torque'] in values:
            self._targets[0] = values[OD['target_torque']]
        if OD['target_position'] in values:
            self._targets[1] = values[OD['target_position']]
        if OD['modes_of_operation'] in values and values[OD['modes_of_operation']] in \
                SUPPORTED_MODES:
            self.mode = values[OD['modes_of_operation']]
        self._controlword(values.get(OD['controlword'], self._cw))

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if not self._operational():
            return
        if self._pending_rpdo is not None:
            data_in, self._pending_rpdo = self._pending_rpdo, None
            self._take_rpdo(data_in)
        self._syncs += 1
        kind = self._raw(0x1800, 2)
        if kind <= 240 and self._syncs % max(kind, 1) == 0:
            self.send_tpdo()

    def tick(self, now: float) -> None:
        """An event-driven TPDO (types 254, 255): on its event timer, and when the statusword
        changed (called at the bench's every tick)."""
        if not self._operational() or self._raw(0x1800, 2) <= 240:
            return
        timer_ms = self._raw(0x1800, 5)
        if self.statusword() != self._last_sw or \
                (timer_ms and now - self._last_tpdo >= timer_ms * 1e-3):
            self._last_tpdo = now
            self.send_tpdo()

    def send_tpdo(self) -> None:
        """TPDO 1 as mapped, now."""
        if not self._tx_valid or not self._tpdo:
            return
        values = {OD['statusword']: self.statusword(), OD['modes_display']: self.mode,
                  OD['position_actual']: self.scale.counts(self.bench.servo.phi),
                  OD['torque_actual']: self._torque_permille(), 0x603F: self.error_code}
        self._last_sw = values[OD['statusword']]
        fmt = '<' + ''.join(code for _, code in self._tpdo)
        data = struct.pack(fmt, *(values.get(od, 0) for od, _ in self._tpdo))
        with contextlib.suppress(Exception):
            self.network.send_message(self._tx_cob, data)

    # --- CiA 402 --------------------------------------------------------------------------
    def _torque_permille(self) -> int:
        s = self.scale
        return max(-32768, min(32767, round(1000.0 * self.bench.servo.torque / s.gear_ratio /
                                            s.rated_torque_nm)))

    def statusword(self) -> int:
        """The state's bits and the others (module docstring)."""
        sw = STATUSWORD[self.state] | 0x0200                            # remote
        if self.state in (State.SWITCHED_ON, State.OPERATION_ENABLED,
                          State.QUICK_STOP_ACTIVE):
            sw |= 0x0010                                                # voltage enabled
        if self.state == State.OPERATION_ENABLED and self.mode in SUPPORTED_MODES:
            sw |= 0x1000                                                # follows the command
            if self._target_reached():
                sw |= 0x0400
        return sw

    def _target_reached(self) -> bool:
        s = self.scale
        if self.mode == MODE_CSP:
            return abs(s.counts(self.bench.servo.phi) - self._targets[1]) <= \
                max(1, round(2 ** s.encoder_bits_per_rev / 1000))      # a thousandth of a turn
        return abs(self._torque_permille() - self._targets[0]) <= 20   # 2 % of the rated

    def _controlword(self, cw: int) -> None:
        before = self.state
        self.state, self._cw = next_402(self.state, cw, self._cw), cw
        if before == State.FAULT and self.state != State.FAULT:       # the fault reset
            self.error_code = 0
            with contextlib.suppress(Exception):
                self.node.emcy.reset(0)
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
            with self.lock:
                self.bench.command_load(*wanted)

    def _error_register(self) -> int:
        if not self.error_code:
            return 0
        return 0x01 | _ERROR_CLASS.get(self.error_code >> 12, 0)

    # --- faults (the tests of the drivers) --------------------------------------------------
    def emcy(self, code: int = 0x2310) -> None:
        """The drive faults (default: over-current): its EMCY, error register, 0x603F and
        history (module docstring)."""
        self.state = State.FAULT
        self.error_code = code
        self.errors = ([code] + self.errors)[:HISTORY]
        self._apply()
        self.node.emcy.send(code, self._error_register())

    def silence(self) -> None:
        """The drive stops talking: no heartbeat, no PDO, no SDO (a cut cable)."""
        self.silent = True
        with contextlib.suppress(Exception):
            self.node.nmt.stop_heartbeat()

    def talk(self) -> None:
        """The drive talks again after ``silence``, in whatever power state it was left."""
        self.silent = False
        period = self._raw(0x1017, 0)
        if period:
            with contextlib.suppress(Exception):
                self.node.nmt.start_heartbeat(period)
