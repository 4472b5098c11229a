"""The bench behind real buses (issue 44): the buses' own latencies, a protocol through them
against lock-step, and the host's stall floor beside it.

1. **Modbus TCP**: the DAQ driver's client against the emulated DAQ on 127.0.0.1, the outputs
   written and the inputs read in one round trip per exchange, as fast as they go for a few
   seconds: the achieved exchange rate and each exchange's round trip (p50, p99); then
   pymodbus' synchronous client making the same requests one after the other.
2. **CAN**: 8-byte frames (a PDO's size) through the hub between two python-can clients, one at
   a time (ping-pong): the frame's latency.
3. **A protocol through the buses**: ``isometric_quick`` (quick: the 6-reading settled series)
   with ``--wallclock --buses --seed 3`` against the lock-step run of the same seed: the
   readings' largest force and contraction differences, the sequencer's control period (p99,
   late share) and the drivers' achieved rates.
4. **The host's stall floor**: during 3, a cyclictest-like probe in its own process sleeps
   1 ms a million times over and records how late each wake-up is: what the machine alone
   does to a 1 kHz loop, to set the bench's own lateness against.
5. **Faults across the buses**: each bus fault in the short isometric series of
   ``benchmarks.faults`` (4 readings), with suspenders on the four inputs: what the run did
   (suspended and resumed by itself, or aborted vented), how long it was held, and, after an
   abort, a ``--resume`` through the buses that takes the readings the bag lacks.

6. **The torque servo through the buses**: ``servo_sin_t`` with ``--wallclock --buses``
   (two valves and two load cells on the DAQ, the drive holding the pulley on CAN) against
   the scene's twin (the lock-step reference): the torque RMS of each, the servo's control
   period (p99, late share) and the drivers' rates, with the host's stall floor probed
   beside it as in 4.
"""

from __future__ import annotations

import os
import pathlib
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table

__all__ = ['STUDY', 'probe_wakeups']

SETTLED = """description: short isometric series (the buses study, quick)
exchange_step_s: 1.5
protocol: isometric_quick
protocol_overrides: {x_m: [0.04, 0.04, 0.01], voltage_v: [0.0, 2.0, 1.0], dwell_s: 1.5}
nodes: [valve_1, muscle_1, load_cell_1, encoder, loading_servo, sequencer, recorder]
"""


def _pct(values: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values), q)) if values else float('nan')


def _pymodbus_exchange(rmap: Any, port: int) -> tuple[Callable[[], None], Any]:
    """The exchange as pymodbus' synchronous client makes it, one request per block (the
    driver's client before it sent them together), and the client (to close)."""
    from pymodbus.client import ModbusTcpClient

    from pam_bench.buses.modbus_io import ModbusIo
    client = ModbusTcpClient('127.0.0.1', port=port, timeout=0.05, retries=0)
    client.connect()
    frames = ModbusIo(rmap, '127.0.0.1', port)
    words = {b.address: list(struct.unpack(f'>{b.count}H', frames._write_pdu(
        b, {'valve_1.voltage': 2.0})[6:])) for b in rmap.blocks(True)}

    def exchange() -> None:
        for address, ws in words.items():
            client.write_registers(address, ws, device_id=rmap.device_id)
        for b in rmap.blocks(False):
            call = (client.read_input_registers if b.register == 'input'
                    else client.read_holding_registers)
            call(b.address, count=b.count, device_id=rmap.device_id)
    return exchange, client


def _modbus(seconds: float) -> dict[str, Any]:
    """The driver's exchange (outputs and inputs in one round trip), then pymodbus' client
    doing the same requests one by one, against the same emulated DAQ."""
    from pam_bench.buses.can_hub import bus_config, can_hub
    from pam_bench.buses.modbus_io import ModbusIo
    from pam_bench.buses.register_map import load_register_map
    from pam_bench.cluster.loopback import free_port
    from pam_bench.twin.bench import SingleMuscleBench
    from pam_bench.twin.buses import EmulatedBench
    rmap = load_register_map('daq_generic')
    out: dict[str, Any] = {}
    with can_hub() as hub:
        port = free_port()
        emu = EmulatedBench(SingleMuscleBench(), rmap, port,
                            bus_config('socketcand', 'can0', hub.port)).start()
        io = ModbusIo(rmap, '127.0.0.1', port)
        try:
            io.connect()
            n, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < seconds:
                io.exchange({'valve_1.voltage': 2.0})
                n += 1
            wall = time.perf_counter() - t0
            trips = io.take_round_trips()
            io.close()
            out = {'rate_hz': n / wall, 'round_trip_p50_ms': _pct(trips, 50) * 1e3,
                   'round_trip_p99_ms': _pct(trips, 99) * 1e3, 'requests': len(trips)}
            other, client = _pymodbus_exchange(rmap, port)
            n, t0 = 0, time.perf_counter()
            times = []
            while time.perf_counter() - t0 < seconds:
                t = time.perf_counter()
                other()
                times.append(time.perf_counter() - t)
                n += 1
            client.close()
            out['pymodbus'] = {'rate_hz': n / (time.perf_counter() - t0),
                               'exchange_p50_ms': _pct(times, 50) * 1e3,
                               'exchange_p99_ms': _pct(times, 99) * 1e3, 'exchanges': n}
        finally:
            io.close()
            emu.stop()
    return out


def _can(frames: int) -> dict[str, Any]:
    import can

    from pam_bench.buses.can_hub import bus_config, can_hub
    lat: list[float] = []
    with can_hub() as hub:
        a, b = (can.Bus(**bus_config('socketcand', 'can0', hub.port)) for _ in range(2))
        try:
            time.sleep(0.1)
            for k in range(frames):
                t = time.perf_counter()
                a.send(can.Message(arbitration_id=0x185, data=bytes(8), is_extended_id=False))
                got = b.recv(1.0)
                lat.append(time.perf_counter() - t)
                assert got is not None and got.arbitration_id == 0x185, k
        finally:
            a.shutdown()
            b.shutdown()
    return {'frame_p50_ms': _pct(lat, 50) * 1e3, 'frame_p99_ms': _pct(lat, 99) * 1e3,
            'frames': frames}


def probe_wakeups(seconds: float, period_s: float = 0.001) -> dict[str, float]:
    """Sleep ``period_s`` again and again for ``seconds``: how late each wake-up is (ms)."""
    late: list[float] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        t = time.perf_counter()
        time.sleep(period_s)
        late.append(time.perf_counter() - t - period_s)
    a = np.asarray(late) * 1e3
    return {'wakeups': int(a.size), 'p50_ms': float(np.percentile(a, 50)),
            'p99_ms': float(np.percentile(a, 99)), 'max_ms': float(a.max()),
            'over_1ms_share': float(np.mean(a > 1.0))}


def _through_buses(quick: bool) -> dict[str, Any]:
    import json

    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    from pam_bench.verify.wallclock import compare_readings
    from pam_bench.vocabulary.run import Layout, RunOptions
    with tempfile.TemporaryDirectory(prefix='pam_bench_buses_') as tmp:
        if quick:
            path = pathlib.Path(tmp) / 'settled.yaml'
            path.write_text(SETTLED)
            scene = load_scene(str(path))
        else:
            scene = load_scene('isometric_quick')
        lock = run_scene(scene, f'{tmp}/lock', RunOptions(seed=3, quiet=True))
        probe = subprocess.Popen([sys.executable, '-c', 'import json, sys; from '
                                  'benchmarks.buses import probe_wakeups; '
                                  'print(json.dumps(probe_wakeups(float(sys.argv[1]))))',
                                  str(15.0 if quick else 140.0)],
                                 stdout=subprocess.PIPE, text=True,
                                 env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
        t0 = time.monotonic()
        bus = run_scene(scene, f'{tmp}/bus', RunOptions(seed=3, quiet=True,
                                                        layout=Layout.WALL_CLOCK,
                                                        buses='daq_generic'))
        wall = time.monotonic() - t0
        floor = json.loads(probe.communicate(timeout=300)[0] or '{}')
        out: dict[str, Any] = {'scene': scene.name, 'lock_code': lock.code,
                               'bus_code': bus.code, 'wall_s': wall, 'floor': floor}
        if lock.code == 0 and bus.code == 0:
            d = compare_readings(f'{tmp}/bus', f'{tmp}/lock')
            out.update(matched=d.matched, only_bus=d.only_a, only_lock=d.only_b,
                       max_force_n=d.max_force_n, max_contraction_m=d.max_contraction_m)
        for name in ('sequencer', 'daq_modbus', 'servo_canopen'):
            per = (bus.stats.get(name) or {}).get('periods')
            if per:
                out[name] = {'p99_ms': per['p99_s'] * 1e3, 'late_share': per['late_share'],
                             'rate_hz': 1.0 / per['mean_s'], 'max_ms': per['max_s'] * 1e3}
        return out


def _servo_through_buses(quick: bool) -> dict[str, Any]:
    import dataclasses
    import json

    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    from pam_bench.twin.servo_bench import run_servo, tracking_metrics
    from pam_bench.twin.servo_setup import scene_servo_setup, servo_run_of_bag
    from pam_bench.vocabulary.run import Layout, RunOptions
    scene = load_scene('servo_sin_t')
    if quick:
        scene = dataclasses.replace(scene, duration_s=3.0)
    s = scene_servo_setup(scene)
    twin = tracking_metrics(run_servo(
        scene.settings()['torque_servo'].controller, s['signal'], scene.duration_s,
        s['angle_rad'], scene.exchange_step_s, s['inverse'], s['muscles'], s['params'],
        s['valve'], s['muscle'], plugins=s['plugins']))
    with tempfile.TemporaryDirectory(prefix='pam_bench_servo_buses_') as tmp:
        probe = subprocess.Popen([sys.executable, '-c', 'import json, sys; from '
                                  'benchmarks.buses import probe_wakeups; '
                                  'print(json.dumps(probe_wakeups(float(sys.argv[1]))))',
                                  str(scene.duration_s + 6.0)],
                                 stdout=subprocess.PIPE, text=True,
                                 env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
        bus = run_scene(scene, f'{tmp}/bus', RunOptions(quiet=True, layout=Layout.WALL_CLOCK,
                                                        buses='daq_generic'))
        floor = json.loads(probe.communicate(timeout=300)[0] or '{}')
        out: dict[str, Any] = {'scene': scene.name, 'duration_s': scene.duration_s,
                               'bus_code': bus.code, 'floor': floor,
                               'twin_rms_nm': twin['rms_error']}
        if bus.code == 0:
            out['bus_rms_nm'] = tracking_metrics(servo_run_of_bag(
                pathlib.Path(tmp) / 'bus', 2))['rms_error']
        for name in ('torque_servo', 'daq_modbus', 'servo_canopen'):
            per = (bus.stats.get(name) or {}).get('periods')
            if per:
                out[name] = {'p99_ms': per['p99_s'] * 1e3, 'late_share': per['late_share'],
                             'rate_hz': 1.0 / per['mean_s'], 'max_ms': per['max_s'] * 1e3}
        return out


BUS_FAULTS = {
    # kind: fault entry (times from the protocol's start; readings at 3.0, 4.5, 6.0, 7.5 s)
    'modbus_down': '{kind: modbus_down, target: daq_modbus, at_s: 4.0, duration_s: 0.6}',
    'register_out_of_range': '{kind: register_out_of_range, target: daq_modbus, at_s: 4.0, '
                             'duration_s: 0.5, value: 50000.0}',
    'can_silent': '{kind: can_silent, target: servo_canopen, at_s: 3.6, duration_s: 0.6}',
    'can_emcy': '{kind: can_emcy, target: servo_canopen, at_s: 3.6}',
}
"""The bus faults tried: each in the short isometric series of ``benchmarks.faults``."""
EVERY_INPUT = ('[{{input: force, low: -50.0, high: 1000.0, stale_s: 0.2, resume_after_s: 0.3}}, '
               '{{input: contraction, stale_s: 0.2, resume_after_s: 0.3}}, '
               '{{input: pressure, stale_s: 0.2, resume_after_s: 0.3}}, '
               '{{input: drive, stale_s: 0.2, resume_after_s: 0.3}}]')
"""Suspenders on the four inputs (a latched EMCY gets none on ``drive``: nothing resets the
drive in a study, so the run aborts and ``--resume`` takes the rest)."""


def _stamp_s(msg: Any) -> float:
    return int(msg.header.stamp.sec) + int(msg.header.stamp.nanosec) * 1e-9


def _bus_fault(kind: str, tmp: pathlib.Path) -> dict[str, Any]:
    from benchmarks.faults import READINGS, SCENE
    from pam_bench.bags.bagread import topic_messages
    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    from pam_bench.vocabulary.run import Layout, RunOptions
    old = ('[{{input: force, low: -50.0, high: 1000.0, stale_s: 0.2,\n    '
           'resume_after_s: 0.3}}]')
    rules = EVERY_INPUT if kind != 'can_emcy' else EVERY_INPUT.replace(
        ', {{input: drive, stale_s: 0.2, resume_after_s: 0.3}}', '')
    folder = tmp / kind
    folder.mkdir()
    path = folder / 'bus_fault.yaml'
    path.write_text(SCENE.replace(old, rules).format(fault=BUS_FAULTS[kind]), encoding='utf-8')
    bag = tmp / f'{kind}_bag'
    res = run_scene(load_scene(str(path)), str(bag),
                    RunOptions(layout=Layout.WALL_CLOCK, quiet=True, buses='daq_generic'))
    status = topic_messages(bag, '/protocol/status')
    taken = {(p.series, p.step) for p in topic_messages(bag, '/protocol/point')}
    paused = [s for s in status if s.phase == 'paused']
    held = [_stamp_s(s) for s in status if s.phase != 'paused' and paused
            and _stamp_s(s) > _stamp_s(paused[0])]
    out: dict[str, Any] = {
        'code': res.code, 'readings': READINGS, 'taken': len(taken),
        'reason': (paused[0].reason if paused else status[-1].reason if status else ''),
        'suspended_s': (held[0] - _stamp_s(paused[0])) if paused and held else None}
    if res.code == 4:                              # aborted: the rest by --resume
        again = tmp / f'{kind}_again'
        again.mkdir()
        (again / 'bus_fault.yaml').write_text(SCENE.replace(old, rules).format(fault=''),
                                              encoding='utf-8')
        rest = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run',
                               str(again / 'bus_fault.yaml'), '--wallclock', '--buses',
                               'daq_generic', '--resume', str(bag), '--out',
                               str(tmp / f'{kind}_rest')], capture_output=True, text=True,
                              timeout=300)
        more = ({(p.series, p.step) for p in topic_messages(tmp / f'{kind}_rest',
                                                            '/protocol/point')}
                if rest.returncode == 0 else set())
        out.update(resume_code=rest.returncode, resumed=len(more),
                   overlap=len(more & taken))
    return out


def _bus_faults() -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix='pam_bench_bus_faults_') as tmp:
        return {kind: _bus_fault(kind, pathlib.Path(tmp)) for kind in BUS_FAULTS}


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """The six measurements (module docstring)."""
    return {'buses': {'modbus': _modbus(3.0 if quick else 10.0),
                      'can': _can(500 if quick else 5000),
                      'run': _through_buses(quick),
                      'servo': _servo_through_buses(quick),
                      'faults': _bus_faults()}}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """Bus latencies, the run against lock-step, the host's floor."""
    b = r['buses']
    m, c, run = b['modbus'], b['can'], b['run']
    lines = table(['bus', 'what', 'p50', 'p99', 'rate'], [
        ('Modbus TCP (127.0.0.1)', f"the driver's exchange (write and read sent together), "
         f"{m['requests']} exchanges", f"{m['round_trip_p50_ms']:.3f} ms",
         f"{m['round_trip_p99_ms']:.3f} ms", f"{m['rate_hz']:.0f} exchanges/s"),
        *([('Modbus TCP (127.0.0.1)', "pymodbus' synchronous client, write then read, "
            f"{m['pymodbus']['exchanges']} exchanges",
            f"{m['pymodbus']['exchange_p50_ms']:.3f} ms",
            f"{m['pymodbus']['exchange_p99_ms']:.3f} ms",
            f"{m['pymodbus']['rate_hz']:.0f} exchanges/s")] if 'pymodbus' in m else []),
        ('CAN (socketcand hub)', f"8-byte frame, one at a time, {c['frames']} frames",
         f"{c['frame_p50_ms']:.3f} ms", f"{c['frame_p99_ms']:.3f} ms", '-'),
    ])
    lines += ['']
    if 'matched' in run:
        lines += [f"{run['scene']} with `--wallclock --buses --seed 3` against lock-step "
                  f"(seed 3): {run['matched']} readings matched ({run['only_bus']} only "
                  f"through the buses, {run['only_lock']} only in lock-step), largest "
                  f"difference {run['max_force_n']:.2f} N and "
                  f"{run['max_contraction_m'] * 1e3:.3f} mm (bounds 10 N, 0.2 mm); "
                  f"{run['wall_s']:.0f} s on the wall clock.", '']
    else:
        lines += [f"{run['scene']}: lock-step exit {run['lock_code']}, through the buses exit "
                  f"{run['bus_code']}.", '']
    lines += table(['loop during the run', 'rate', 'period p99', 'period max', 'late'],
                   _loop_rows(run, ('sequencer', 'daq_modbus', 'servo_canopen')))
    sv = b.get('servo')
    if sv:
        lines += ['', _servo_line(sv), '']
        lines += table(['loop during the servo run', 'rate', 'period p99', 'period max',
                        'late'], _loop_rows(sv, ('torque_servo', 'daq_modbus', 'servo_canopen')))
    faults = b.get('faults')
    if faults:
        lines += ['', 'Each bus fault in the short isometric series of "Injected faults" (4 '
                  'readings), at 3.6 or 4.0 s into the protocol, with suspenders (stale 0.2 s, '
                  'resume after 0.3 s) on force, contraction, pressure and the drive (none on '
                  'the drive for the latched EMCY: nothing resets the drive here).', '']
        frows = []
        for kind, f in faults.items():
            did = ('suspended, resumed, done' if f['code'] == 0 and f['suspended_s'] is not None
                   else 'done' if f['code'] == 0 else f"aborted (exit {f['code']})")
            after = (f"{f['taken']} + {f['resumed']} by --resume (exit {f['resume_code']}, "
                     f"{f['overlap']} twice)" if 'resume_code' in f else str(f['taken']))
            held = f"{f['suspended_s']:.2f} s" if f['suspended_s'] is not None else '-'
            frows.append((f'`{kind}`', did, f['reason'][:90], held,
                          f"{after} of {f['readings']}"))
        lines += table(['fault', 'the run', 'reason on protocol/status', 'held', 'readings'],
                       frows)
    return lines


def _loop_rows(run: dict[str, Any], names: tuple[str, ...]
               ) -> list[tuple[str, str, str, str, str]]:
    """One row per loop of ``names`` the run measured, then the host's stall floor beside it."""
    rows = [(n, f"{run[n]['rate_hz']:.0f} Hz", f"{run[n]['p99_ms']:.3f} ms",
             f"{run[n]['max_ms']:.1f} ms", f"{run[n]['late_share'] * 100:.2f} %")
            for n in names if n in run]
    f = run.get('floor') or {}
    if f:
        rows.append(('host floor (1 ms sleeps, own process)', f"{f['wakeups']} wake-ups",
                     f"{f['p99_ms']:.3f} ms late", f"{f['max_ms']:.1f} ms late",
                     f"{f['over_1ms_share'] * 100:.2f} % over 1 ms"))
    return rows


def _servo_line(sv: dict[str, Any]) -> str:
    if 'bus_rms_nm' not in sv:
        return f"{sv['scene']} through the buses: exit {sv['bus_code']}."
    return (f"{sv['scene']} ({sv['duration_s']:.0f} s) with `--wallclock --buses`: torque RMS "
            f"{sv['bus_rms_nm']:.3f} N m against {sv['twin_rms_nm']:.3f} N m for the scene's "
            f"twin (the lock-step reference), a difference of "
            f"{abs(sv['bus_rms_nm'] - sv['twin_rms_nm']):.3f} N m (bound 0.1 N m).")


def results(r: dict[str, Any]) -> list[Row]:
    """The run through the buses against lock-step, and the Modbus rate."""
    b = r.get('buses')
    if not b:
        return []
    run = b['run']
    rows: list[Row] = [('Modbus TCP exchange (write + read) on 127.0.0.1', '1 kHz',
                        f"{b['modbus']['rate_hz']:.0f} /s, p99 round trip "
                        f"{b['modbus']['round_trip_p99_ms']:.2f} ms", commit_of(r, 'buses'))]
    if 'matched' in run:
        rows.append((f"{run['scene']} through the buses vs lock-step (seed 3)",
                     '<= 10 N, 0.2 mm', f"{run['max_force_n']:.2f} N, "
                     f"{run['max_contraction_m'] * 1e3:.3f} mm", commit_of(r, 'buses')))
    if 'daq_modbus' in run:
        d = run['daq_modbus']
        rows.append((f"{run['scene']} through the buses: daq_modbus rate, late share",
                     '>= 990 Hz, < 1 %', f"{d['rate_hz']:.0f} Hz, {d['late_share'] * 100:.2f} %",
                     commit_of(r, 'buses')))
    sv = b.get('servo') or {}
    if 'torque_servo' in sv:
        t = sv['torque_servo']
        rows.append((f"{sv['scene']} through the buses: torque servo period p99, late share",
                     '<= 1.1 ms, <= 0.5 %', f"{t['p99_ms']:.3f} ms, {t['late_share'] * 100:.2f} %",
                     commit_of(r, 'buses')))
    if 'bus_rms_nm' in sv:
        rows.append((f"{sv['scene']} through the buses: torque RMS against its twin",
                     '<= 0.1 N m', f"{abs(sv['bus_rms_nm'] - sv['twin_rms_nm']):.3f} N m "
                     f"({sv['bus_rms_nm']:.3f} against {sv['twin_rms_nm']:.3f})",
                     commit_of(r, 'buses')))
    return rows


STUDY = Study('buses', 'the bench behind Modbus TCP and CANopen: latencies, a protocol against '
              'lock-step, the host floor', measure, (('buses', section),), results)
