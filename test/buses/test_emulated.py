"""The bench behind its buses, met by the drivers' bus clients (no ROS): values, commands, the
drive's state machine, and each fault the drivers must detect."""

from __future__ import annotations

import math
import struct
import sys
import threading
import time
from collections.abc import Callable, Iterator

import can
import pytest

from pam_bench.buses.can_hub import bus_config, can_hub
from pam_bench.buses.canopen_drive import CanopenDrive, eds_path
from pam_bench.buses.cia402 import DriveScale, State
from pam_bench.buses.errors import BusUnreachable
from pam_bench.buses.modbus_io import Backoff, ModbusIo
from pam_bench.buses.register_map import load_register_map
from pam_bench.cluster.loopback import free_port
from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.models.loading_servo import LoadMode
from pam_bench.twin.bench import SingleMuscleBench
from pam_bench.twin.buses import EmulatedBench
from pam_bench.twin.modbus_server import ModbusServer


class Rig:
    def __init__(self, port: int, hub_port: int) -> None:
        self.map = load_register_map('daq_generic')
        self.emu = EmulatedBench(SingleMuscleBench(), self.map, port,
                                 bus_config('socketcand', 'can0', hub_port)).start()
        self.io = ModbusIo(self.map, '127.0.0.1', port)
        self.io.connect()
        self.drive = CanopenDrive(bus_config('socketcand', 'can0', hub_port), 5, eds_path(),
                                  DriveScale())
        self.drive.start()

    def run(self, seconds: float, voltage: float = 0.0) -> dict[str, float]:
        end, values = time.monotonic() + seconds, {}
        while time.monotonic() < end:
            self.io.write_outputs({'valve_1.voltage': voltage})
            values = self.io.read_inputs()
            self.drive.tick(time.monotonic())
            time.sleep(0.002)
        return values

    def run_until(self, done: Callable[[], bool], timeout_s: float = 10.0,
                  voltage: float = 0.0) -> None:
        """Exchange until ``done()`` (a loaded machine takes longer: no fixed window)."""
        end = time.monotonic() + timeout_s
        while not done() and time.monotonic() < end:
            self.run(0.02, voltage)
        assert done(), 'not reached in time'


@pytest.fixture
def rig() -> Iterator[Rig]:
    with can_hub() as hub:
        r = Rig(free_port(), hub.port)
        try:
            yield r
        finally:
            r.drive.stop()
            r.io.close()
            r.emu.stop()


def test_values_commands_and_the_drive(rig: Rig) -> None:
    rig.drive.command(LoadMode.POSITION, 0.04)
    values = rig.run(1.5, voltage=3.0)
    assert rig.drive.state == State.OPERATION_ENABLED and rig.emu.state == State.OPERATION_ENABLED
    assert rig.emu.valve_voltage_v == pytest.approx(3.0)
    b = rig.emu.bench
    assert b.x == pytest.approx(0.04, abs=2e-4)            # held where the drive was told
    assert values['valve_1.pressure'] == pytest.approx(b.p + ATMOSPHERE_PA, rel=0.01)
    assert values['encoder.angle'] == pytest.approx(0.04 / DriveScale().radius_m, abs=2e-3)
    assert values['load_cell_1.force'] == pytest.approx(b.f, abs=5.0)
    rig.drive.command(LoadMode.FORCE, 150.0)               # the mode changes through SDO
    rig.run(1.5, voltage=0.0)
    assert rig.emu.mode == 10 and rig.drive.state == State.OPERATION_ENABLED
    assert b.f == pytest.approx(150.0, abs=15.0)
    rig.drive.command(LoadMode.OFF, 0.0)
    rig.run(0.2)
    assert rig.emu.state == State.READY_TO_SWITCH_ON        # power stage off


def test_an_emcy_is_a_fault_the_driver_keeps(rig: Rig) -> None:
    rig.drive.command(LoadMode.POSITION, 0.02)
    rig.run_until(lambda: rig.emu.state == State.OPERATION_ENABLED)
    rig.emu.emcy(0x2310)
    rig.run_until(lambda: 'EMCY 0x2310' in rig.drive.fault)
    assert rig.emu.state == State.FAULT
    rig.run(0.3)
    assert rig.emu.state == State.FAULT                    # left there until a reset
    rig.drive.reset()
    rig.run_until(lambda: rig.emu.state == State.OPERATION_ENABLED)


def test_a_silent_drive_goes_stale_and_is_enabled_again_when_it_talks(rig: Rig) -> None:
    rig.drive.command(LoadMode.POSITION, 0.02)
    rig.run_until(lambda: rig.emu.state == State.OPERATION_ENABLED)
    assert not rig.drive.stale(time.monotonic())
    rig.emu.silence_can()
    rig.run_until(lambda: rig.drive.stale(time.monotonic()))  # the driver sends quick stop
    rig.emu.talk_can()                                     # heard again: quick stop, then on
    rig.run_until(lambda: not rig.drive.stale(time.monotonic()))
    rig.run_until(lambda: rig.drive.state == rig.emu.state == State.OPERATION_ENABLED)


def test_a_lost_server_and_a_corrupt_register(rig: Rig) -> None:
    rig.emu.corrupt('load_cell_1.force', 5.0e4, 0.5)     # 50 kN: outside the map's range
    values = rig.run(0.1)
    assert math.isnan(values['load_cell_1.force']) and math.isfinite(values['encoder.angle'])
    time.sleep(0.5)
    assert math.isfinite(rig.run(0.05)['load_cell_1.force'])
    rig.emu.stop_modbus()
    with pytest.raises(BusUnreachable):
        rig.run(0.5)


def test_the_hub_relays_to_the_others_only() -> None:
    with can_hub() as hub:
        a, b = (can.Bus(**bus_config('socketcand', 'can0', hub.port)) for _ in range(2))
        try:
            time.sleep(0.1)
            a.send(can.Message(arbitration_id=0x181, data=b'\x01\x02', is_extended_id=False))
            a.send(can.Message(arbitration_id=0x1ABCDE, data=b'', is_extended_id=True))
            got = [b.recv(1.0), b.recv(1.0)]
            assert [(m.arbitration_id, bytes(m.data), m.is_extended_id) for m in got] == \
                [(0x181, b'\x01\x02', False), (0x1ABCDE, b'', True)]
            assert a.recv(0.2) is None                      # no echo
        finally:
            a.shutdown()
            b.shutdown()


def test_nothing_listens_one_error() -> None:
    io = ModbusIo(load_register_map('daq_generic'), '127.0.0.1', free_port())
    with pytest.raises(BusUnreachable, match='127.0.0.1'):
        io.connect()
    backoff = Backoff(0.1, 0.5)
    for expected in (0.1, 0.2, 0.4, 0.5, 0.5):
        assert backoff.delay_s == pytest.approx(expected)
        backoff.failed(0.0)


def test_a_read_never_tears_a_value_between_two_ticks() -> None:
    """The two words of a float32 come from one tick: a reader racing the ticks sees only
    values the bench measured (a torn float is a value it never had, and check-drivers saw
    one as a step of 0.00049 N)."""
    rmap = load_register_map('daq_generic')
    bench = SingleMuscleBench()
    forces = (0.6103515625, -0.67138671875)              # 10 and -11 counts of 0.061 N
    tick = [0]

    def signals() -> dict[str, float]:
        tick[0] += 1
        return {'load_cell_1.force': forces[tick[0] % 2]}

    bench.signals = signals                                  # type: ignore[method-assign]
    emu = EmulatedBench(bench, rmap, 0, bus_config('socketcand', 'can0', free_port()))
    server = ModbusServer(rmap, 0, emu._read_words, emu._write_words)
    force = next(c for c in rmap.inputs if c.signal == 'load_cell_1.force')
    request = struct.pack('>BHH', 4 if force.register == 'input' else 3, force.address,
                          force.count)
    stop = threading.Event()

    def ticks() -> None:
        while not stop.is_set():
            emu._publish_inputs()

    t = threading.Thread(target=ticks)
    t.start()
    seen: set[float] = set()
    try:
        sys.setswitchinterval(1e-6)                      # switch threads as often as it can
        for _ in range(20000):
            reply = server.answer(request)
            seen.add(rmap.decode(force, list(struct.unpack(f'>{force.count}H', reply[2:]))))
    finally:
        sys.setswitchinterval(0.005)
        stop.set()
        t.join()
    assert seen <= set(forces), sorted(seen)
