"""The loading servo's driver side of CANopen: a CiA 402 drive configured by SDO, commanded by
RPDO, read by TPDO, watched by heartbeat and EMCY.

``CanopenDrive.start`` configures the drive as a CiA 402 master does: NMT pre-operational, the
heartbeat period (0x1017), RPDO 1 mapped to controlword, target torque and target position and
TPDO 1 to statusword, torque actual and position actual (each mapping disabled, rewritten,
enabled, as CiA 301 asks), the rated torque read back (0x6076), then NMT start. Every tick
(``tick``) sends RPDO 1 with the controlword that leads the power state machine
(``buses.cia402``) towards operation enabled while a load is wanted and towards ready to switch
on (the power stage off) otherwise, and the set value in the drive's units (``DriveScale``),
then a SYNC, at which the drive sends TPDO 1 (transmission type 1); a change of mode goes by
SDO (0x6060) with the drive off first.

Watching: a TPDO updates the state and the actuals; an EMCY is kept as ``fault`` (the drive
then shows FAULT and the driver leaves it there until told to ``reset``); no heartbeat for
``heartbeat_timeout_s`` makes the drive ``stale``, and then the driver sends quick stop.
"""

from __future__ import annotations

import contextlib
import struct
import time
from typing import Any

from pam_bench.buses.cia402 import (
    CONTROLWORD,
    MODE_CSP,
    MODE_CST,
    OD,
    Command,
    DriveScale,
    State,
    command_towards,
    state_of,
)
from pam_bench.buses.errors import BusUnreachable
from pam_bench.models.loading_servo import LoadMode

__all__ = ['CanopenDrive', 'RPDO_MAP', 'TPDO_MAP', 'eds_path', 'open_network']


def open_network(can: dict[str, Any]) -> Any:
    """A ``canopen.Network`` connected to the bus ``can`` (python-can's keywords,
    ``can_hub.bus_config``).

    Raises:
        BusUnreachable: the bus cannot be opened (one line naming it).
    """
    import canopen
    network = canopen.Network()
    try:
        network.connect(**can)
    except Exception as exc:  # noqa: BLE001 - python-can raises several types
        raise BusUnreachable(f'CAN bus {can.get("interface")} {can.get("channel")}: '
                             f'{exc}') from None
    if network.notifier is not None:
        network.notifier.add_listener(_BusLost(network))
    return network


class _BusLost:
    """A listener of python-can's notifier that ends its receive thread quietly when the bus
    fails (a socketcand server that went away): the error is kept on the network
    (``bus_error``) and the thread stops, instead of raising the error in a thread that prints
    its traceback over the run's output. The drive's heartbeat watch then says the drive fell
    silent, as it does for any lost drive."""

    def __init__(self, network: Any) -> None:
        self.network = network
        network.bus_error = ''

    def __call__(self, msg: Any) -> None:
        """A frame: nothing to do here."""

    def on_message_received(self, msg: Any) -> None:
        """A frame: nothing to do here."""

    def on_error(self, exc: Exception) -> None:
        """The bus failed: keep why, end the receive thread (SystemExit ends a thread
        silently)."""
        self.network.bus_error = f'{type(exc).__name__}: {exc}'
        raise SystemExit


def eds_path() -> str:
    """The EDS of the loading-servo drive the bench emulates (config/buses/loading_servo.eds)."""
    from pam_bench.config.paths import config_dir
    return str(config_dir() / 'buses' / 'loading_servo.eds')

RPDO_MAP = ((OD['controlword'], 16), (OD['target_torque'], 16), (OD['target_position'], 32))
"""RPDO 1: what the driver sends every tick (index, bits)."""
TPDO_MAP = ((OD['statusword'], 16), (OD['torque_actual'], 16), (OD['position_actual'], 32))
"""TPDO 1: what the drive sends every tick (index, bits)."""
_RPDO_FMT, _TPDO_FMT = '<Hhi', '<Hhi'
RPDO_TYPE = 255
"""RPDO 1's transmission type: the drive takes it at once."""
TPDO_TYPE = 1
"""TPDO 1's transmission type: the drive sends it at every SYNC, which the driver sends after
each RPDO (its cycle is the master's, as CiA 301 synchronous PDOs run)."""


class CanopenDrive:
    """A CiA 402 drive over canopen (module docstring).

    Args:
        can: python-can keywords of the bus (``buses.can_hub.bus_config``).
        node_id: the drive's node id.
        eds: its EDS file.
        scale: its units.
        heartbeat_ms: the heartbeat period asked of the drive (0x1017).
        heartbeat_timeout_s: no heartbeat this long: the drive is stale.
    """

    def __init__(self, can: dict[str, Any], node_id: int, eds: str, scale: DriveScale,
                 heartbeat_ms: int = 100, heartbeat_timeout_s: float = 0.35) -> None:
        self.can = can
        self.node_id = node_id
        self.eds = eds
        self.scale = scale
        self.heartbeat_ms = heartbeat_ms
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.network: Any = None
        self.node: Any = None
        self.state = State.NOT_READY_TO_SWITCH_ON
        self.torque_permille = 0
        self.position_counts = 0
        self.last_tpdo_s: float | None = None
        self.last_heartbeat_s: float | None = None
        self.fault = ''                      # the last EMCY, until reset
        self.mode = 0                        # the mode of operation set by SDO
        self.wanted: tuple[LoadMode, float] = (LoadMode.OFF, 0.0)
        self._cw = 0

    # --- set-up ---------------------------------------------------------------------------
    def start(self) -> None:
        """Connect and configure the drive (module docstring).

        Raises:
            BusUnreachable: the bus cannot be opened, or the drive does not answer.
        """
        import canopen
        self.network = open_network(self.can)
        try:
            self.node = canopen.RemoteNode(self.node_id, self.eds)
        except Exception as exc:  # noqa: BLE001 - a bad EDS: its parser's words
            raise BusUnreachable(f'EDS {self.eds}: {exc}') from None
        self.network.add_node(self.node)
        self.node.sdo.RESPONSE_TIMEOUT = 0.5
        self.network.subscribe(0x700 + self.node_id, self._on_heartbeat)
        self.network.subscribe(0x180 + self.node_id, self._on_tpdo)
        self.node.emcy.add_callback(self._on_emcy)
        try:
            self.node.nmt.send_command(0x80)                      # pre-operational
            self._sdo(0x1017, 0, struct.pack('<H', self.heartbeat_ms))
            self._map(0x1400, 0x1600, 0x200, RPDO_MAP, RPDO_TYPE)
            self._map(0x1800, 0x1A00, 0x180, TPDO_MAP, TPDO_TYPE)
            rated = struct.unpack('<I', self.node.sdo.upload(OD['rated_torque'], 0))[0]
            if rated:
                self.scale.rated_torque_nm = rated * 1e-3
            self._set_mode(MODE_CSP)
        except Exception as exc:  # noqa: BLE001 - SDO timeouts and aborts
            raise BusUnreachable(f'CANopen drive {self.node_id}: no answer to its '
                                 f'configuration ({exc})') from None
        self.node.nmt.send_command(0x01)                          # start
        self.last_heartbeat_s = time.monotonic()

    def _sdo(self, index: int, sub: int, data: bytes) -> None:
        self.node.sdo.download(index, sub, data)

    def _map(self, com: int, mapping: int, base: int, entries: tuple[tuple[int, int], ...],
             kind: int) -> None:
        """Disable a PDO, write its mapping and transmission type ``kind``, enable it (the
        order CiA 301 asks)."""
        cob = base + self.node_id
        self._sdo(com, 1, struct.pack('<I', cob | 0x80000000))
        self._sdo(com, 2, bytes([kind]))
        self._sdo(mapping, 0, b'\x00')
        for k, (index, bits) in enumerate(entries, 1):
            self._sdo(mapping, k, struct.pack('<I', index << 16 | bits))
        self._sdo(mapping, 0, bytes([len(entries)]))
        self._sdo(com, 1, struct.pack('<I', cob))

    def _set_mode(self, mode: int) -> None:
        self._sdo(OD['modes_of_operation'], 0, struct.pack('<b', mode))
        self.mode = mode

    def stop(self) -> None:
        """Turn the drive off (shutdown) and leave the bus."""
        if self.network is None:
            return
        with contextlib.suppress(Exception):
            self._send(CONTROLWORD[Command.SHUTDOWN], 0, 0)
        with contextlib.suppress(Exception):
            self.network.disconnect()

    # --- watching ---------------------------------------------------------------------------
    def _on_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self.last_heartbeat_s = time.monotonic()

    def _on_tpdo(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) != struct.calcsize(_TPDO_FMT):
            return
        sw, self.torque_permille, self.position_counts = struct.unpack(_TPDO_FMT, bytes(data))
        self.state = state_of(sw)
        self.last_tpdo_s = time.monotonic()

    def _on_emcy(self, error: Any) -> None:
        if error.code == 0:           # the error-reset EMCY: the drive's fault is gone, and
            return                    # what the driver keeps is cleared by ``reset`` only
        self.fault = f'EMCY 0x{error.code:04X} ({error.get_desc() or "no text"})'

    def stale(self, now: float) -> bool:
        """No heartbeat for ``heartbeat_timeout_s`` at ``now`` (monotonic s)."""
        return self.last_heartbeat_s is None or \
            now - self.last_heartbeat_s > self.heartbeat_timeout_s

    # --- commanding -------------------------------------------------------------------------
    def command(self, mode: LoadMode, setpoint: float) -> None:
        """What the drive should do from the next tick: off, a muscle tension (N) or a
        contraction (m)."""
        self.wanted = (mode, setpoint)

    def reset(self) -> None:
        """Clear a kept fault: the next ticks reset the drive's fault."""
        self.fault = ''

    def tick(self, now: float) -> None:
        """Send RPDO 1 (module docstring): quick stop when stale, the drive left in FAULT
        while a fault is kept, else the controlword towards the wanted state."""
        mode, value = self.wanted
        if self.stale(now):
            self._send(CONTROLWORD[Command.QUICK_STOP], 0, self.position_counts)
            return
        if self.fault:
            self._send(CONTROLWORD[Command.DISABLE_VOLTAGE], 0, self.position_counts)
            return
        want_mode = {LoadMode.FORCE: MODE_CST, LoadMode.POSITION: MODE_CSP}.get(mode, 0)
        if want_mode and want_mode != self.mode:
            if self.state == State.OPERATION_ENABLED:       # off first, then the new mode
                self._send(CONTROLWORD[Command.SHUTDOWN], 0, self.position_counts)
                return
            self._set_mode(want_mode)
        cw = command_towards(self.state, operate=bool(want_mode))
        if cw == CONTROLWORD[Command.FAULT_RESET] and self._cw & 0x80:
            cw = CONTROLWORD[Command.DISABLE_VOLTAGE]        # an edge: low, then high
        torque = self.scale.torque_permille(value) if mode == LoadMode.FORCE else 0
        position = (self.scale.counts(value / self.scale.radius_m) if mode == LoadMode.POSITION
                    else self.position_counts)
        self._send(cw, torque, position)

    def _send(self, cw: int, torque: int, position: int) -> None:
        """Send RPDO 1.

        Raises:
            BusUnreachable: the bus is gone (its interface or the hub closed).
        """
        self._cw = cw
        try:
            self.network.send_message(0x200 + self.node_id,
                                      struct.pack(_RPDO_FMT, cw, torque, position))
            self.network.send_message(0x80, b'')                    # SYNC: the TPDO comes
        except Exception as exc:  # noqa: BLE001 - python-can and the OS raise several types
            raise BusUnreachable(f'CAN bus {self.can.get("interface")} '
                                 f'{self.can.get("channel")} lost: {exc}') from None
