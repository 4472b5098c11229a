"""The emulated drive as a standard master sees it (issue 52): canopen's own CiA 402 master,
``BaseNode402``, drives it through enable, a mode change, quick stop, a fault and its reset;
SDO and PDO views agree; NMT resets, stopped, the PDO rules, EMCY and the error history
behave as CiA 301 says; the EDS passes a CiA 306 checker with no finding."""

from __future__ import annotations

import pathlib
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import canopen
import pytest
from canopen.profiles.p402 import BaseNode402
from canopen.sdo import SdoAbortedError

from pam_bench.buses.can_hub import bus_config, can_hub
from pam_bench.buses.canopen_drive import eds_path, open_network
from pam_bench.buses.cia402 import DriveScale
from pam_bench.twin.bench import SingleMuscleBench
from pam_bench.twin.cia402_drive import ABORT, EmulatedDrive

NODE = 5


class Stand:
    """The emulated drive over a simulated bench, and a standard master on the same bus."""

    def __init__(self, hub_port: int) -> None:
        self.bench = SingleMuscleBench()
        self.lock = threading.Lock()
        self.drive = EmulatedDrive(self.bench, self.lock, bus_config('socketcand', 'can0',
                                                                       hub_port),
                                   NODE, DriveScale())
        self.drive.start()
        self.network = open_network(bus_config('socketcand', 'can0', hub_port))
        self.boot: list[float] = []
        self.emcy: list[int] = []
        self.network.subscribe(0x700 + NODE, self._heard)
        self.node = BaseNode402(NODE, eds_path())
        self.network.add_node(self.node)
        self.node.sdo.RESPONSE_TIMEOUT = 1.0
        self.node.emcy.add_callback(lambda e: self.emcy.append(e.code))
        self._stop = threading.Event()
        self._ticker = threading.Thread(target=self._tick, daemon=True)
        self._ticker.start()
        self.node.nmt.wait_for_heartbeat(5.0)    # the master's end of the bus is up

    def _heard(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if bytes(data) == b'\x00':
            self.boot.append(timestamp)

    def _tick(self) -> None:
        while not self._stop.is_set():
            with self.lock:
                self.bench.step(0.002)
            self.drive.tick(time.monotonic())
            time.sleep(0.002)

    def close(self) -> None:
        self._stop.set()
        self._ticker.join(2.0)
        for net in (self.network,):
            net.sync.stop()
            net.disconnect()
        self.drive.stop()


@pytest.fixture
def stand() -> Iterator[Stand]:
    with can_hub() as hub:
        s = Stand(hub.port)
        try:
            yield s
        finally:
            s.close()


def _operational(stand: Stand) -> BaseNode402:
    node = stand.node
    node.nmt.state = 'PRE-OPERATIONAL'
    node.setup_402_state_machine()          # reads the PDO set-up by SDO
    node.nmt.state = 'OPERATIONAL'
    stand.network.sync.start(0.01)          # TPDO 1 is synchronous (type 1)
    time.sleep(0.1)
    return node


def test_base_node_402_drives_the_drive_through_its_states(stand: Stand) -> None:
    node = _operational(stand)
    node.state = 'OPERATION ENABLED'
    assert node.state == 'OPERATION ENABLED' and stand.drive.state.value == 'operation enabled'
    assert node.statusword & 0x0210 == 0x0210          # remote and voltage enabled
    assert node.is_op_mode_supported('CYCLIC SYNCHRONOUS TORQUE')
    assert not node.is_op_mode_supported('PROFILED VELOCITY')
    node.state = 'SWITCHED ON'                           # a mode changes with the drive off
    node.op_mode = 'CYCLIC SYNCHRONOUS TORQUE'
    assert node.op_mode == 'CYCLIC SYNCHRONOUS TORQUE' and stand.drive.mode == 10
    node.state = 'OPERATION ENABLED'
    assert node.statusword & 0x1000                      # follows the command value
    node.state = 'QUICK STOP ACTIVE'
    assert stand.drive.state.value == 'quick stop active'
    node.state = 'OPERATION ENABLED'
    stand.drive.emcy(0x2310)
    time.sleep(0.1)
    assert node.is_faulted() and stand.emcy[-1] == 0x2310
    node.reset_from_fault()
    assert not node.is_faulted() and node.state == 'OPERATION ENABLED'
    assert stand.emcy[-1] == 0x0000                      # the error-reset EMCY


def test_an_unsupported_mode_is_refused(stand: Stand) -> None:
    with pytest.raises(SdoAbortedError) as err:
        stand.node.sdo.download(0x6060, 0, struct.pack('<b', 3))    # profiled velocity
    assert err.value.code == ABORT['range']
    assert stand.node.sdo.upload(0x6502, 0) == struct.pack('<I', 0x280)


def test_sdo_and_pdo_views_of_an_object_agree(stand: Stand) -> None:
    node = _operational(stand)
    node.op_mode = 'CYCLIC SYNCHRONOUS POSITION'
    node.state = 'OPERATION ENABLED'
    node.sdo.download(0x607A, 0, struct.pack('<i', 4000))     # a target by SDO is taken
    time.sleep(0.5)
    by_sdo = struct.unpack('<i', node.sdo.upload(0x6064, 0))[0]
    node.tpdo[1].wait_for_reception(1.0)
    by_pdo = node.tpdo[1]['Position actual value'].raw
    assert by_sdo == pytest.approx(4000, abs=40) and by_pdo == pytest.approx(by_sdo, abs=40)
    sw_pdo = node.tpdo[1]['Statusword'].raw
    assert struct.unpack('<H', node.sdo.upload(0x6041, 0))[0] == sw_pdo


def test_nmt_resets_stopped_and_the_boot_up(stand: Stand) -> None:
    node = stand.node
    node.sdo.download(0x1017, 0, struct.pack('<H', 250))
    node.nmt.state = 'OPERATIONAL'
    stand.boot.clear()
    node.nmt.state = 'RESET'                             # reset node
    time.sleep(0.3)
    assert stand.boot, 'no boot-up message after a reset'
    assert stand.drive.node.nmt.state == 'PRE-OPERATIONAL'
    assert struct.unpack('<H', node.sdo.upload(0x1017, 0))[0] == 100     # default again
    node.nmt.state = 'STOPPED'
    time.sleep(0.1)
    node.sdo.RESPONSE_TIMEOUT = 0.3
    with pytest.raises(canopen.SdoCommunicationError):
        node.sdo.upload(0x1000, 0)                       # no SDO in stopped


def _sdo_abort(node: Any, index: int, sub: int, data: bytes) -> int:
    with pytest.raises(SdoAbortedError) as err:
        node.sdo.download(index, sub, data)
    return err.value.code


def test_the_pdo_rules_and_their_abort_codes(stand: Stand) -> None:
    node = stand.node
    node.nmt.state = 'PRE-OPERATIONAL'
    # the mapping of a valid PDO cannot change
    assert _sdo_abort(node, 0x1A00, 1, struct.pack('<I', 0x60410010)) == ABORT['incompatible']
    node.sdo.download(0x1800, 1, struct.pack('<I', 0x80000185))      # invalid first
    assert _sdo_abort(node, 0x1A00, 1, struct.pack('<I', 0x60410010)) == ABORT['incompatible']
    node.sdo.download(0x1A00, 0, b'\x00')                             # then count 0
    assert _sdo_abort(node, 0x1A00, 1, struct.pack('<I', 0x60760020)) == \
        ABORT['not mappable']                                         # rated torque: no
    assert _sdo_abort(node, 0x1A00, 1, struct.pack('<I', 0x60410020)) == \
        ABORT['not mappable']                                         # wrong length
    for k, entry in enumerate((0x60640020, 0x607A0020, 0x60410010), 1):
        node.sdo.download(0x1A00, k, struct.pack('<I', entry))
    assert _sdo_abort(node, 0x1A00, 0, b'\x03') == ABORT['too long']  # 80 bits
    assert _sdo_abort(node, 0x1800, 2, b'\xf5') == ABORT['range']     # reserved type
    node.sdo.download(0x1A00, 0, b'\x02')
    node.sdo.download(0x1800, 1, struct.pack('<I', 0x185))            # valid again
    assert _sdo_abort(node, 0x1800, 1, struct.pack('<I', 0x1A5)) == ABORT['range']


def test_emcy_the_error_register_and_the_history_agree(stand: Stand) -> None:
    node = stand.node
    stand.drive.emcy(0x3210)                             # over-voltage
    time.sleep(0.1)
    assert stand.emcy[-1] == 0x3210
    assert node.sdo.upload(0x1001, 0) == bytes([0x01 | 0x04])       # generic + voltage
    assert struct.unpack('<H', node.sdo.upload(0x603F, 0))[0] == 0x3210
    assert node.sdo.upload(0x1003, 0) == b'\x01'
    assert struct.unpack('<I', node.sdo.upload(0x1003, 1))[0] == 0x3210
    node.sdo.download(0x1003, 0, b'\x00')                            # the history cleared
    assert node.sdo.upload(0x1003, 0) == b'\x00'


def test_the_eds_passes_a_cia_306_checker() -> None:
    """eds-utils' validator reports nothing on the shipped EDS (it prints each finding)."""
    checker = pathlib.Path(sys.executable).with_name('eds-validate')
    res = subprocess.run([str(checker), eds_path()], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0 and not (res.stdout + res.stderr).strip(), res.stdout
