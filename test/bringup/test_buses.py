"""The bench behind real buses on the wall clock: the drivers replace the simulated devices and
the sequencer and the recorder run unchanged (issue 44)."""

from __future__ import annotations

import pathlib
import subprocess
import sys
import time

import pytest

from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.verify.wallclock import CONTRACTION_BOUND_M, FORCE_BOUND_N, compare_readings
from pam_bench.vocabulary.run import Layout, RunOptions
from test.bringup.test_wallclock import SETTLED
from test.helpers import bag_messages

pytestmark = pytest.mark.wallclock


def test_a_run_through_the_buses_lands_on_the_lockstep_readings(tmp_path: pathlib.Path,
                                                                ros_domain: int) -> None:
    path = tmp_path / 'settled.yaml'
    path.write_text(SETTLED)
    scene = load_scene(str(path))
    lock = run_scene(scene, str(tmp_path / 'lock'), RunOptions(quiet=True))
    assert lock.code == 0
    res = run_scene(scene, str(tmp_path / 'bus'),
                    RunOptions(layout=Layout.WALL_CLOCK, quiet=True, buses='daq_generic'))
    assert res.code == 0, res.summary
    assert {'daq_modbus', 'servo_canopen', 'sequencer', 'recorder'} <= set(res.stats)
    diff = compare_readings(tmp_path / 'bus', tmp_path / 'lock')
    assert diff.matched == 6 and diff.only_a == diff.only_b == 0
    assert diff.max_force_n <= FORCE_BOUND_N, diff
    assert diff.max_contraction_m <= CONTRACTION_BOUND_M, diff
    from mcap.reader import make_reader  # the MCAP project's own reader too
    from mcap_ros2.decoder import DecoderFactory

    from pam_bench.bags.baginfo import bag_info
    mcap_file = next((tmp_path / 'bus').glob('*.mcap'))
    with open(mcap_file, 'rb') as fh:
        points = [ros for _, _, _, ros in make_reader(
            fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                topics=['/protocol/point'])]
    assert len(points) == 6
    assert bag_info(str(tmp_path / 'bus'))['end']['state'] == 'done'
    states = bag_messages(tmp_path / 'bus', '/loading_servo/state')      # from the drive
    assert states and all(s.name[0] == 'motor' for s in states[-10:])
    diags = bag_messages(tmp_path / 'bus', '/diagnostics')
    names = {st.name for d in diags for st in d.status}
    assert 'daq_modbus: bus' in names and 'servo_canopen: drive' in names


def test_check_drivers_passes_on_the_bus_drivers(tmp_path: pathlib.Path,
                                                 ros_domain: int) -> None:
    proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'emulate', 'demo',
                             '--buses'], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            if 'running on the wall clock' in line:
                break
        time.sleep(2.0)
        res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'check-drivers', 'demo',
                              '--duration', '2'], capture_output=True, text=True, timeout=60)
    finally:
        proc.terminate()
        proc.wait(timeout=20)
    assert res.returncode == 0, res.stdout + res.stderr
    assert '6 of 6 pass' in res.stdout        # loading_servo/state among them


def test_a_bad_register_map_starts_nothing(tmp_path: pathlib.Path, ros_domain: int) -> None:
    bad = tmp_path / 'map.yaml'
    bad.write_text('channels:\n  - {signal: load_cell_1.force, adress: 0, low: 0, high: 1}\n')
    res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', 'demo', '--wallclock',
                          '--buses', str(bad), '--out', str(tmp_path / 'bag')],
                         capture_output=True, text=True, timeout=60)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and len(lines) == 1 and "'adress'" in lines[0], res.stderr
    assert not (tmp_path / 'bag').exists() or not any((tmp_path / 'bag').iterdir())


def _level(status: object) -> int:
    level = status.level                     # bytes from rclpy, an int from rosbags
    return level[0] if isinstance(level, bytes) else int(level)


BUS_FAULTS = ('{kind: modbus_down, target: daq_modbus, at_s: 3.6, duration_s: 0.6}, '
              '{kind: register_out_of_range, target: daq_modbus, at_s: 5.6, duration_s: 0.5, '
              'value: 50000.0}, '
              '{kind: can_silent, target: servo_canopen, at_s: 7.6, duration_s: 0.6}')
"""Three bus faults in one run, each over before the next (times from the protocol's start)."""


def test_bus_faults_are_detected_suspend_the_run_and_lose_no_reading(
        tmp_path: pathlib.Path, ros_domain: int) -> None:
    """The DAQ's server goes away, then its load-cell register holds 50 kN, then the drive
    falls silent: each is its driver's diagnostic (STALE, a rejected reading, STALE with quick
    stop), each stops the topics it carries, and suspenders on the four inputs suspend the run
    vented until the device is back; every reading is taken."""
    from benchmarks.buses import EVERY_INPUT
    from benchmarks.faults import READINGS, SCENE
    path = tmp_path / 'bus_faults.yaml'
    text = SCENE.replace('[{{input: force, low: -50.0, high: 1000.0, stale_s: 0.2,\n    '
                         'resume_after_s: 0.3}}]', EVERY_INPUT)
    assert text != SCENE
    path.write_text(text.format(fault=BUS_FAULTS))
    res = run_scene(load_scene(str(path)), str(tmp_path / 'bag'),
                    RunOptions(layout=Layout.WALL_CLOCK, quiet=True, buses='daq_generic'))
    bag = tmp_path / 'bag'
    status = bag_messages(bag, '/protocol/status')
    assert res.code == 0, (res.summary, [s.reason for s in status])
    assert len(bag_messages(bag, '/protocol/point')) == READINGS
    paused = {s.reason for s in status if s.phase == 'paused'}
    assert any('force stale' in r for r in paused) and any('drive stale' in r for r in paused), \
        paused
    diags = [st for d in bag_messages(bag, '/diagnostics') for st in d.status]
    daq = [st for st in diags if st.name.startswith('daq_modbus')]
    drive = [st for st in diags if st.name == 'servo_canopen: drive']
    assert any(_level(st) == 3 and 'lost' in st.message for st in daq)           # STALE
    assert any('rejected' in st.message and 'load_cell_1.force' in st.message for st in daq)
    assert any(_level(st) == 3 and 'quick stop' in st.message for st in drive)   # STALE


def test_a_drive_fault_stops_the_run_vented_and_resume_takes_the_rest(
        tmp_path: pathlib.Path, ros_domain: int) -> None:
    """An EMCY: a fault diagnostic, the drive disabled and its state gone, so the sequencer
    aborts on the stale ``loading_servo/state`` with the valve vented and the drive off; a
    ``--resume`` through the buses takes the readings the bag lacks, none lost or repeated."""
    from benchmarks.faults import READINGS, SCENE
    (tmp_path / 'first').mkdir()
    (tmp_path / 'again').mkdir()
    path = tmp_path / 'first' / 'drive.yaml'
    path.write_text(SCENE.format(fault='{kind: can_emcy, target: servo_canopen, at_s: 3.6}'))
    res = run_scene(load_scene(str(path)), str(tmp_path / 'bag'),
                    RunOptions(layout=Layout.WALL_CLOCK, quiet=True, buses='daq_generic'))
    bag = tmp_path / 'bag'
    drive = [st for d in bag_messages(bag, '/diagnostics') for st in d.status
             if st.name == 'servo_canopen: drive']
    assert any(_level(st) == 2 and 'EMCY 0x2310' in st.message for st in drive), \
        (res.code, [st.message for st in drive])
    status = bag_messages(bag, '/protocol/status')
    assert res.code == 4 and 'loading_servo/state stale' in status[-1].reason, \
        (res.summary, [s.reason for s in status])
    assert bag_messages(bag, '/valve_1/command')[-1].voltage == 0.0
    assert bag_messages(bag, '/loading_servo/command')[-1].mode == 0
    first = {(p.series, p.step) for p in bag_messages(bag, '/protocol/point')}
    assert 1 <= len(first) < READINGS     # after the first reading (3.0 s), before the second
    again = tmp_path / 'again' / 'drive.yaml'          # the same scene, its fault repaired
    again.write_text(SCENE.format(fault=''))
    out = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', str(again),
                          '--wallclock', '--buses', 'daq_generic', '--resume', str(bag),
                          '--out', str(tmp_path / 'rest')], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    rest = [(p.series, p.step) for p in bag_messages(tmp_path / 'rest', '/protocol/point')]
    assert len(set(rest)) == len(rest) and not first & set(rest)
    assert len(first) + len(rest) == READINGS


def test_the_torque_servo_runs_through_the_buses_as_in_lock_step(tmp_path: pathlib.Path,
                                                                 ros_domain: int) -> None:
    """servo_sin_t with its two valves and two load cells on the DAQ and the drive holding the
    pulley on CAN: the torque it tracks within 0.1 N m RMS of the same scene's twin (the
    lock-step nodes' reference, bit-equal to them: test/twin)."""
    import dataclasses

    from pam_bench.twin.servo_bench import run_servo, tracking_metrics
    from pam_bench.twin.servo_setup import scene_servo_setup, servo_run_of_bag
    scene = dataclasses.replace(load_scene('servo_sin_t'), duration_s=3.0)
    res = run_scene(scene, str(tmp_path / 'bus'),
                    RunOptions(layout=Layout.WALL_CLOCK, quiet=True, buses='daq_generic'))
    assert res.code == 0, res.summary
    bus = tracking_metrics(servo_run_of_bag(tmp_path / 'bus', 2))
    s = scene_servo_setup(scene)
    twin = tracking_metrics(run_servo(
        scene.settings()['torque_servo'].controller, s['signal'], scene.duration_s, s['angle_rad'],
        scene.exchange_step_s, s['inverse'], s['muscles'], s['params'], s['valve'],
        s['muscle'], plugins=s['plugins']))
    assert abs(bus['rms_error'] - twin['rms_error']) <= 0.1, (bus, twin, _troubles(
        tmp_path / 'bus'))
    drive = bag_messages(tmp_path / 'bus', '/loading_servo/state')       # the drive holds
    assert drive and all(abs(m.position[0]) < 1e-3 for m in drive[-10:])


def _troubles(bag: pathlib.Path) -> list[str]:
    """Each distinct warning, error or stale status on the bag's /diagnostics, with the time of
    its first appearance (what a failed run through the buses says about itself)."""
    seen: dict[str, float] = {}
    for m in bag_messages(bag, '/diagnostics'):
        for st in m.status:
            if st.level != b'\x00' and st.level != 0:
                seen.setdefault(f'{st.name}: {st.message}',
                                m.header.stamp.sec + m.header.stamp.nanosec * 1e-9)
    return [f'{t:.3f} {k}' for k, t in sorted(seen.items(), key=lambda kv: kv[1])]

