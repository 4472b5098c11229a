"""daq_modbus: the driver of a Modbus TCP DAQ carrying the valves, the load cells and the encoder.

Thin node over ``buses.modbus_io``: every ``1 / rate_hz`` s one exchange, the valve voltages
written and the inputs read in one round trip (``register_map``), then the readings out as the
driver contract has them (``docs/drivers.md``): ``valve_N/pressure`` (absolute Pa),
``load_cell_N/force``, ``encoder/joint_state`` (joint ``joint_name``), stamped at the read,
reliable. Inputs: ``valve_N/command`` for each valve the map carries; a command that is not
finite or outside the map's range is rejected (counted, diagnosed) and the valve vents (0 V).

A reading the map refuses (out of its range: a broken wire, a flipped register) is rejected and
not published: the controllers see that topic go stale. A request that times out or a lost
connection puts the outputs in their safe state (every valve 0 V at the first write after),
stops the readings (stale downstream), says so on ``/diagnostics`` (level STALE, concern
``bus``) and reconnects with a back-off (0.1 s, doubling, at most ``reconnect_max_s``). The
1 Hz summary carries the achieved exchange rate and the round trip's p50 and p99.
"""

from __future__ import annotations

import functools
import math
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.msg import ValveCommand
from sensor_msgs.msg import FluidPressure, JointState

from pam_bench.buses.errors import BusUnreachable
from pam_bench.buses.modbus_io import Backoff, ModbusIo
from pam_bench.buses.register_map import load_register_map
from pam_bench.config import topics
from pam_bench.config.settings import DaqModbusSettings
from pam_bench.runtime.base import SENSOR, BenchNode
from pam_bench.runtime.messages import force_reading
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import stamped

__all__ = ['DaqModbusNode', 'main']


class DaqModbusNode(BenchNode):
    """Thin node over ``ModbusIo`` (module docstring)."""

    SETTINGS = DaqModbusSettings

    def __init__(self, name: str = 'daq_modbus', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: DaqModbusSettings = self.settings
        self.map = load_register_map(s.register_map)
        self.io = ModbusIo(self.map, s.host, s.port, s.timeout_s)
        self.backoff = Backoff(0.1, s.reconnect_max_s)
        self.connected = False
        self.voltages: dict[str, float] = {c.signal: 0.0 for c in self.map.outputs}
        self.pubs: dict[str, tuple[Any, str]] = {}
        for c in self.map.inputs:
            device, _ = c.signal.split('.')
            if device.startswith('valve_'):
                ch = int(device[-1])
                self.pubs[c.signal] = (self.create_step_publisher(
                    FluidPressure, topics.valve_pressure(ch)), device)
            elif device.startswith('load_cell_'):
                ch = int(device[-1])
                self.pubs[c.signal] = (self.create_step_publisher(
                    WrenchStamped, topics.load_cell_force(ch)), device)
            else:
                self.pubs[c.signal] = (self.create_step_publisher(JointState, topics.ENCODER),
                                       'encoder')
        for c in self.map.outputs:
            ch = int(c.signal.split('.')[0][-1])
            self.create_subscription(ValveCommand, topics.valve_command(ch),
                                     functools.partial(self._command, c.signal), SENSOR)
        self.exchanges = 0
        self._rate_since = (time.monotonic(), 0)
        self.start_wall_ticks(1.0 / s.rate_hz)

    def _command(self, signal: str, msg: ValveCommand) -> None:
        """A valve command: kept for the next write; a bad one is rejected and vents."""
        c = self.map.channel(signal)
        assert c is not None
        u = float(msg.voltage)
        if not (math.isfinite(u) and c.low <= u <= c.high):
            self.reject(f'{signal} command', u)
            u = 0.0
        self.voltages[signal] = u

    def on_wall_tick(self, t_ns: int | None = None) -> None:
        """One exchange: write the voltages, read the inputs, publish them."""
        self.count_tick()
        now = time.monotonic()
        if not self.connected:
            if not self.backoff.due(now):
                return
            try:
                self.io.connect()
            except BusUnreachable as exc:
                self.backoff.failed(now)
                self.diagnose(DiagnosticStatus.STALE, f'DAQ unreachable: {exc}', 'bus')
                return
            self.connected = True
            self.backoff.reset()
            self.diagnose(DiagnosticStatus.OK, f'DAQ connected: {self.map.name}', 'bus')
        try:
            values = self.io.exchange(self.voltages)
        except BusUnreachable as exc:
            self._lost(now, str(exc))
            return
        t = self.now_ns()
        self.exchanges += 1
        for signal, value in values.items():
            if not math.isfinite(value):
                self.reject(f'{signal} reading outside the range of the map', value)
                continue
            pub, device = self.pubs[signal]
            if device == 'encoder':
                pub.publish(stamped(JointState, t, name=[self.settings.joint_name],
                                    position=[value], velocity=[0.0], effort=[0.0]))
            elif device.startswith('valve_'):
                pub.publish(stamped(FluidPressure, t, device, fluid_pressure=value,
                                    variance=0.0))
            else:
                pub.publish(force_reading(t, device, value))
        self._summary(now)

    def _lost(self, now: float, text: str) -> None:
        """Connection lost: outputs safe at the next write, inputs stale, reconnect later."""
        self.connected = False
        self.io.close()
        self.voltages = dict.fromkeys(self.voltages, 0.0)
        self.backoff.failed(now)
        self.diagnose(DiagnosticStatus.STALE, f'DAQ connection lost ({text}): valves 0 V on '
                      'reconnect, readings stopped', 'bus')

    def _summary(self, now: float) -> None:
        since, n0 = self._rate_since
        if now - since < 1.0:
            return
        trips = sorted(self.io.take_round_trips())
        rate = (self.exchanges - n0) / (now - since)
        self._rate_since = (now, self.exchanges)
        if trips:
            self.diagnose(DiagnosticStatus.OK, f'DAQ exchanging at {rate:.0f} Hz', 'bus',
                          rate_hz=round(rate, 1),
                          round_trip_p50_ms=round(trips[len(trips) // 2] * 1e3, 3),
                          round_trip_p99_ms=round(trips[min(len(trips) - 1,
                                                            int(0.99 * len(trips)))] * 1e3, 3))

    def on_fault(self, reason: str) -> None:
        """A failed tick: every valve to 0 V at the next write."""
        self.voltages = dict.fromkeys(self.voltages, 0.0)

    def safe_state(self) -> None:
        """Every valve to 0 V, written now (best effort: a lost DAQ's watchdog vents)."""
        self.voltages = dict.fromkeys(self.voltages, 0.0)
        if self.connected:
            try:
                self.io.write_outputs(self.voltages)
            except BusUnreachable:
                pass

    def destroy_node(self) -> None:
        """Vent before going (best effort), then close the connection."""
        self.safe_state()
        self.io.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(DaqModbusNode, args)


if __name__ == '__main__':
    main()
