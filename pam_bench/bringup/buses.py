"""The bench behind its buses on a wall clock (``run --wallclock --buses``, ``emulate --buses``).

The simulated devices are served by one process, ``twin.serve_buses`` (a Modbus TCP DAQ on
127.0.0.1 and a CiA 402 drive on the CAN hub), and the two drivers (``daq_modbus``,
``servo_canopen``) take their place on the ROS graph, each in its own process as on a real
bench: the sequencer, the servo and the recorder run unchanged. A scene of the torque servo's
pair (``loading_servo.muscles: 2``) puts both valves and both load cells on the DAQ, and the
driver holds the pulley at the scene's angle from the start (its ``initial_mode`` position,
as the simulated drive holds it).
"""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
from collections.abc import Callable, Sequence
from typing import Any

from pam_bench.bringup.errors import LayoutError

__all__ = ['DRIVERS', 'bus_settings', 'start_buses']

DRIVERS = ('daq_modbus', 'servo_canopen')
"""The driver nodes that replace the simulated devices."""
DRIVER_PRIORITY = 45
"""SCHED_FIFO priority of the drivers' exchanges where the machine allows it: below the torque
servo's control loop (50), as a lab's driver of real hardware runs (docs/drivers.md). The
emulated buses' process stays at ordinary priority: at SCHED_FIFO beside the drivers and the
servo, the real-time share of two cores ran out (the kernel's real-time throttling) and the
servo stalled past its stale timeout in one run of two (docs/long_runs.md, "The DAQ at its
contract rate through the buses"); tried again at a third of a core, the servo's test failed
2 of 5 on a noisy host, 0 of 5 at ordinary priority ("The emulated DAQ's server made cheaper,
and real-time tried again")."""


def bus_settings(settings: dict[str, Any], register_map: str, stats_dir: str
                 ) -> tuple[dict[str, Any], tuple[int, int]]:
    """The run's settings with the two drivers added (their ports free on 127.0.0.1 now, the
    drive's units those of the scene's loading servo), and (Modbus port, CAN hub port).

    Raises:
        LayoutError: the scene lacks a device the buses serve.
    """
    from pam_bench.buses.cia402 import DriveScale
    from pam_bench.buses.register_map import load_register_map
    from pam_bench.cluster.loopback import free_port
    from pam_bench.config.settings import DaqModbusSettings, ServoCanopenSettings
    from pam_bench.twin.serve_buses import PAIR
    needed = ['valve_1', 'muscle_1', 'load_cell_1', 'encoder', 'loading_servo']
    pair = 'loading_servo' in settings and settings['loading_servo'].muscles == 2
    if pair:
        needed += PAIR
    missing = [n for n in needed if n not in settings]
    if missing:
        raise LayoutError(f"--buses serves the single-muscle bench or the torque servo's "
                          f'pair: the scene lacks {", ".join(missing)}')
    load_register_map(register_map)            # a bad map: one line before anything starts
    ports = (free_port(), free_port())
    drive = settings['loading_servo']
    servo = drive.servo
    mode, setpoint = drive.initial_mode, drive.initial_setpoint
    if pair and mode == 0:      # the pair's pulley held where the scene holds it (ideal there)
        mode, setpoint = 2, drive.hold_angle_rad * servo.pitch_diameter_m / 2.0
    out = dict(settings)
    out['daq_modbus'] = DaqModbusSettings(
        port=ports[0], register_map=register_map,
        stats_file=os.path.join(stats_dir, 'daq_modbus.json'),
        rate_hz=settings['valve_1'].rate_hz, realtime_priority=DRIVER_PRIORITY)
    out['servo_canopen'] = ServoCanopenSettings(
        can_interface='socketcand', can_port=ports[1],
        stats_file=os.path.join(stats_dir, 'servo_canopen.json'),
        initial_mode=mode, initial_setpoint=setpoint, realtime_priority=DRIVER_PRIORITY,
        drive=DriveScale(servo.pitch_diameter_m, servo.gear_ratio, servo.rated_torque_nm,
                         servo.encoder_bits_per_rev))
    return out, ports


def start_buses(start: Callable[..., subprocess.Popen], pfile: str, ports: tuple[int, int],
                register_map: str, log: Any, faults: Sequence[Any] = (),
                at_start: bool = False) -> subprocess.Popen:
    """Start ``twin.serve_buses`` with the scene's bus faults and wait for its ready line;
    with ``at_start`` the faults' clock starts when the caller writes ``start`` to its stdin
    (the protocol has started), else at once.

    Raises:
        LayoutError: it stopped before serving (its one line).
    """
    import yaml

    from pam_bench.sim.faults import BUS_KINDS
    from pam_bench.twin.serve_buses import READY
    ours = [dataclasses.asdict(f) for f in faults if f.kind in BUS_KINDS]
    proc = start('buses', [sys.executable, '-m', 'pam_bench.twin.serve_buses', pfile,
                           '--modbus-port', str(ports[0]), '--can-port', str(ports[1]),
                           '--map', register_map, '--faults', yaml.safe_dump(ours),
                           *(['--faults-at-start'] if at_start and ours else [])],
                 pipe=True, feed=at_start and bool(ours))
    assert proc.stdout is not None
    for line in proc.stdout:
        log.write(line)
        if line.startswith(READY) and 'error' not in line:
            return proc
        if 'error' in line:
            proc.wait(timeout=10.0)
            raise LayoutError(line.strip())
    proc.wait(timeout=10.0)
    raise LayoutError(f'the bench behind its buses stopped (exit code {proc.returncode})')
