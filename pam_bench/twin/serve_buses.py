"""``python -m pam_bench.twin.serve_buses``: the simulated bench of a scene behind its buses, until
SIGINT or SIGTERM (``pam-bench emulate --buses`` and ``run --wallclock --buses`` start it).

It builds the scene's bench from its device settings (a params file as the bring-up writes
it): the single-muscle bench, or with ``loading_servo.muscles: 2`` the torque servo's pair
(``twin.pair_bench``), and starts the CAN hub on 127.0.0.1 (``buses.can_hub``) and the
``EmulatedBench`` on it and on a Modbus TCP port, prints one line ``buses: modbus
127.0.0.1:PORT, can socketcand 127.0.0.1:PORT, map NAME`` once both serve, and ticks the bench.
A bad register map, a port in use: one line, exit code 2.
"""

from __future__ import annotations

import argparse
import pathlib
import signal
import sys
import threading
from typing import Any

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['bench_of', 'main', 'READY', 'run_faults']

READY = 'buses:'
"""How the ready line starts."""
SWITCH_INTERVAL_S = 2.0e-4
"""How long a thread of this process holds the interpreter before another waiting may run, s
(Python's default: 5 ms)."""


PAIR = ('valve_2', 'muscle_2', 'load_cell_2')
"""The devices a scene adds for the second muscle of the torque servo's pair."""


def bench_of(settings: dict[str, Any]) -> Any:
    """The twin's bench with a scene's device settings (node -> settings): the torque
    servo's pair when the loading servo holds two muscles, else the single-muscle bench."""
    from pam_bench.models.bench_muscle import make_muscle
    from pam_bench.twin.bench import SingleMuscleBench
    from pam_bench.twin.pair_bench import PairBench
    drive = settings['loading_servo']
    if drive.muscles == 2:
        ms = [settings[f'muscle_{i}'] for i in (1, 2)]
        built = [make_muscle(m.muscle, m.straight_fibre, getattr(m, 'laws', None)) for m in ms]
        return PairBench(
            (settings['valve_1'].valve, settings['valve_2'].valve), (built[0], built[1]),
            (settings['load_cell_1'].load_cell, settings['load_cell_2'].load_cell),
            settings['encoder'].encoder, drive.servo, drive.hold_angle_rad,
            drive.rest_contraction_m, (settings['load_cell_1'].seed,
                                       settings['load_cell_2'].seed),
            settings['valve_1'].sub_step_s, ms[0].settle)
    valve, muscle = settings['valve_1'], settings['muscle_1']
    cell = settings['load_cell_1']
    return SingleMuscleBench(valve=valve.valve, muscle=muscle.muscle, load_cell=cell.load_cell,
                             encoder=settings['encoder'].encoder,
                             servo=settings['loading_servo'].servo, seed=cell.seed,
                             sub_step_s=valve.sub_step_s,
                             straight_fibre=muscle.straight_fibre, settle=muscle.settle,
                             laws=getattr(muscle, 'laws', None))


def run_faults(emu: Any, faults: list[Any], stop: threading.Event,
               started: threading.Event | None = None) -> None:
    """Inject each bus fault at its ``at_s`` (s from ``started``: the protocol's start, which
    the bring-up says on stdin; None: from now) until ``stop`` is set; each start and end is
    one line on stdout."""
    import time
    while started is not None and not started.is_set():
        if stop.wait(0.01):
            return
    t0 = time.monotonic()
    pending = sorted(faults, key=lambda f: f.at_s)
    ending: list[tuple[float, Any]] = []
    while not stop.wait(0.01):
        t = time.monotonic() - t0
        while pending and pending[0].at_s <= t:
            f = pending.pop(0)
            print(f'buses: fault {f.kind} at {t:.2f} s', flush=True)
            if f.kind == 'modbus_down':
                emu.stop_modbus()
                ending.append((f.at_s + f.duration_s, f))
            elif f.kind == 'register_out_of_range':
                emu.corrupt('load_cell_1.force', f.value or 5.0e4, f.duration_s)
            elif f.kind == 'can_emcy':
                emu.emcy()
            elif f.kind == 'can_silent':
                emu.silence_can()
                ending.append((f.at_s + f.duration_s, f))
        for end, f in [e for e in ending if e[0] <= t]:
            ending.remove((end, f))
            if f.kind == 'modbus_down':
                emu.restart_modbus()
            else:
                emu.talk_can()
            print(f'buses: fault {f.kind} ended at {t:.2f} s', flush=True)


def main(argv: list[str] | None = None) -> None:
    """Serve (module docstring)."""
    from pam_bench.buses.can_hub import CanHub, bus_config
    from pam_bench.buses.cia402 import DriveScale
    from pam_bench.buses.register_map import load_register_map
    from pam_bench.config.scene import node_of_key, settings_of_params_file
    from pam_bench.runtime.scheduling import set_realtime_priority
    from pam_bench.sim.faults import Fault
    from pam_bench.twin.buses import EmulatedBench
    from pam_bench.vocabulary.yaml_io import load_yaml, read_yaml
    p = argparse.ArgumentParser(prog='python -m pam_bench.twin.serve_buses')
    p.add_argument('params_file')
    p.add_argument('--modbus-port', type=int, required=True)
    p.add_argument('--can-port', type=int, required=True)
    p.add_argument('--map', default='daq_generic')
    p.add_argument('--node-id', type=int, default=5)
    p.add_argument('--priority', type=int, default=0, help='SCHED_FIFO priority where '
                   'allowed (0: ordinary scheduling)')
    p.add_argument('--faults', default='[]', help='YAML list of bus faults (sim.faults)')
    p.add_argument('--faults-at-start', action='store_true', help="the faults' clock starts "
                   'when a line "start" comes on stdin (the protocol has started)')
    args = p.parse_args(argv)
    # One process serves the bench's 1 kHz ticks, the Modbus server and the CAN drive, each a
    # thread: with Python's default 5 ms switch interval a request could wait that long for
    # the interpreter while the ticks ran, and the DAQ's exchange took 2-5 ms instead of 0.4.
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    # --priority: the bench's threads (started below, they inherit it) SCHED_FIFO where
    # allowed; the bring-up leaves it at 0 (``bringup.buses.DRIVER_PRIORITY`` says why).
    print(f'emulated buses: {set_realtime_priority(args.priority)}', flush=True)
    stop = threading.Event()
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    hub = emu = None
    try:
        params = read_yaml(pathlib.Path(args.params_file))
        by_node = {node_of_key(k): v for k, v in params.items()}
        wanted = ('valve_1', 'muscle_1', 'load_cell_1', 'encoder', 'loading_servo',
                  *(n for n in PAIR if n in by_node))
        settings = settings_of_params_file({n: by_node.get(n, {}) for n in wanted})
        rmap = load_register_map(args.map)
        servo = settings['loading_servo'].servo
        scale = DriveScale(servo.pitch_diameter_m, servo.gear_ratio, servo.rated_torque_nm,
                           servo.encoder_bits_per_rev)
        hub = CanHub(args.can_port).start()
        emu = EmulatedBench(bench_of(settings), rmap, args.modbus_port,
                            bus_config('socketcand', 'can0', hub.port), args.node_id, scale,
                            settings['valve_1'].rate_hz).start()
        print(f'{READY} modbus 127.0.0.1:{args.modbus_port}, can socketcand '
              f'127.0.0.1:{hub.port}, map {rmap.name}', flush=True)
        faults = [Fault(**f) for f in load_yaml(args.faults, '--faults') or []]
        started = None
        if args.faults_at_start and faults:
            started = threading.Event()

            def wait_for_start() -> None:
                for line in sys.stdin:
                    if line.strip() == 'start':
                        started.set()
                        return

            threading.Thread(target=wait_for_start, daemon=True).start()
        run_faults(emu, faults, stop, started)
    except PamBenchError as exc:
        print(f'buses: error: {exc}', file=sys.stderr, flush=True)
        sys.exit(2)
    finally:
        if emu is not None:
            emu.stop()
        if hub is not None:
            hub.stop()


if __name__ == '__main__':
    main()
