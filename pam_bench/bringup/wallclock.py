"""A run on the wall clock, as a real bench runs: no sim clock, every node with ``lockstep:
false``.

The recorder starts first, then the devices (by default composed in one emulator process,
``bringup.emulator``; with ``device_processes`` one process each), then the sequencer and the
torque servo; the devices (or the drivers) and the servo are lifecycle nodes that this run
configures and activates (``bringup.lifecycle``). The run ends when the sequencer or the servo
exits (end of the protocol, ``duration_s`` of the servo) or on Ctrl-C; the other nodes are then
stopped, the recorder last.
The recorder records the topics a real bench has (no ``sim/`` ground truth, which would double
what crosses DDS). Every node writes its publish counts and tick periods (``stats_file``),
which come back in ``RunResult.stats`` with the recorder's delivery table, and are kept with
the bag (``STATS_FILE``), interrupted runs included.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import pathlib
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any

import yaml

from pam_bench.bringup.common import (
    RunResult,
    clean_shared_memory,
    copy_lines,
    die_with_parent,
    node_cmd,
    node_error,
    ros_env,
    stop_processes,
    write_end_state,
    write_params_file,
)
from pam_bench.bringup.errors import LayoutError
from pam_bench.bringup.lifecycle import activate_nodes
from pam_bench.config.nodes import controllers, devices
from pam_bench.config.scene import Scene
from pam_bench.vocabulary.outputs import note_output_file

__all__ = ['run_wallclock', 'wall_settings', 'wall_nodes', 'STATS_FILE']

STATS_FILE = 'wall_stats.json'
"""In the bag folder: every node's publish counts and tick periods, and the recorder's counts
(rosbag2 readers ignore it)."""


class _NotStarted(Exception):
    """The recorder stopped before it recorded: the run starts nothing else."""


def wall_settings(scene: Scene, settings: dict[str, Any], stats_dir: str = ''
                  ) -> dict[str, Any]:
    """The settings of ``scene``'s nodes on a wall clock, as ``run --wallclock`` starts them
    and ``params --ros-yaml`` writes them: no sim clock, lock-step off, the servo's duration,
    the scene's faults in their devices, controllers waiting for the recorder, no ``sim/``
    topics recorded; with ``stats_dir`` each node's statistics file in it."""
    rep = dataclasses.replace
    settings = {k: v for k, v in settings.items() if k in scene.nodes}   # no clock
    for name in scene.nodes:
        settings[name] = rep(settings[name], lockstep=False, stats_file=os.path.join(
            stats_dir, f'{name}.json') if stats_dir else '')
    if 'torque_servo' in settings:
        settings['torque_servo'] = rep(settings['torque_servo'], duration_s=scene.duration_s)
    from pam_bench.sim.faults import BUS_KINDS
    for target in {f.target for f in scene.faults
                   if f.kind != 'node_kill' and f.kind not in BUS_KINDS}:
        settings[target] = rep(settings[target], faults_yaml=yaml.safe_dump(
            [dataclasses.asdict(f) for f in scene.faults if f.target == target]))
    for name in controllers(scene.nodes):  # nothing a controller publishes goes unrecorded
        settings[name] = rep(settings[name], await_recorder='recorder' in scene.nodes)
    if 'recorder' in settings:          # what a real bench has: no sim/ ground truth
        rec = settings['recorder']
        settings['recorder'] = rep(rec, step_topics=[
            t for t in rec.step_topics if not t.startswith('/sim/')])
    return settings


def wall_nodes(scene: Scene, devices_only: bool = False, buses: str = '',
               external: tuple[str, ...] = ()) -> list[str]:
    """The ROS nodes a wall-clock run of ``scene`` starts: the recorder, the devices (the
    drivers with ``buses``; not the ``external`` ones) and the controllers; only the devices
    with ``devices_only``."""
    from pam_bench.bringup.buses import DRIVERS
    names = list(DRIVERS) if buses else [d for d in devices(scene.nodes) if d not in external]
    if devices_only:
        return names
    return ['recorder'] * ('recorder' in scene.nodes) + names + controllers(scene.nodes)


def run_wallclock(scene: Scene, settings: dict[str, Any], domain_id: int | None, quiet: bool,
                   device_processes: bool, devices_only: bool = False, namespace: str = '',
                   buses: str = '', external: tuple[str, ...] = ()) -> RunResult:
    """Run the scene on the wall clock (module docstring), every node in ``namespace``; with
    ``buses`` (a register map), the devices behind Modbus TCP and CANopen and the drivers in
    their place (``bringup.buses``); the ``external`` devices left to a lab's drivers, waited
    for before the controllers start (``bringup.external``)."""
    import json

    env = ros_env(domain_id)
    clean_shared_memory()              # what killed runs left in /dev/shm (best effort)
    device_names = [d for d in devices(scene.nodes) if d not in external]
    controller_names = controllers(scene.nodes)
    all_nodes = list(scene.nodes)
    if devices_only:
        scene = dataclasses.replace(scene, nodes=device_names)
        controller_names = []
        device_processes = False
    elif not controller_names:
        raise LayoutError(f'scene {scene.name}: a wall-clock run needs a sequencer or a servo')
    procs: dict[str, subprocess.Popen] = {}
    t0 = time.monotonic()
    code = 0
    with tempfile.TemporaryDirectory(prefix='pam_bench_') as tmp:
        settings = wall_settings(scene, settings, tmp)
        driver_names: list[str] = []
        if buses:
            from pam_bench.bringup.buses import DRIVERS, bus_settings, start_buses
            settings, ports = bus_settings(settings, buses, tmp)
            driver_names = list(DRIVERS)
        # the devices (or the drivers), then the servo: lifecycle nodes the run manages, each
        # configured once the recorder hears its diagnostics (the bag holds its transitions)
        managed = [n for n in (driver_names if buses else device_names) + controller_names
                   if hasattr(settings[n], 'managed')]
        settings = {n: dataclasses.replace(s, managed=True, await_recorder='recorder' in
                                           scene.nodes) if n in managed else s
                    for n, s in settings.items()}
        pfile = os.path.join(tmp, 'params.yaml')
        write_params_file(settings, pfile)
        log = open(os.path.join(tmp, 'nodes.log'), 'w+', encoding='utf-8')

        def start(name: str, cmd: list[str], pipe: bool = False,
                  feed: bool = False) -> subprocess.Popen:
            procs[name] = subprocess.Popen(
                cmd, env=env, stdout=subprocess.PIPE if pipe else log,
                stdin=subprocess.PIPE if feed else None,
                stderr=subprocess.STDOUT, text=True, preexec_fn=die_with_parent)
            return procs[name]

        started = False                    # whether devices and controllers were started
        try:
            if 'recorder' in scene.nodes:
                rec = start('recorder', node_cmd('recorder', pfile, namespace), pipe=True)
                assert rec.stdout is not None
                recording = False
                for line in rec.stdout:      # wait until it has subscribed to its topics
                    log.write(line)
                    recording = line.startswith('recorder: recording')
                    if recording or rec.poll() is not None:
                        break
                if not recording:            # its output ended: it is going, let it go
                    with contextlib.suppress(subprocess.TimeoutExpired):
                        rec.wait(timeout=10.0)
                threading.Thread(target=copy_lines, args=(rec.stdout, log), daemon=True).start()
                if rec.poll() is not None:          # it could not start: nothing else is
                    raise _NotStarted                 # started (its one line is in the log)
            started = True
            if buses:
                bus_proc = start_buses(start, pfile, ports, buses, log, scene.faults,
                                       at_start=not devices_only)
                threading.Thread(target=copy_lines, args=(bus_proc.stdout, log),
                                 daemon=True).start()
                for name in driver_names:
                    start(name, node_cmd(name, pfile, namespace))
            elif device_processes:
                for name in device_names:
                    start(name, node_cmd(name, pfile, namespace))
            elif device_names:                   # external devices: a lab's drivers
                start('emulator', [sys.executable, '-m', 'pam_bench.bringup.emulator',
                                   *(['--namespace', namespace] if namespace else []), pfile,
                                   *device_names])
            def gone(n: str) -> bool:
                return procs[n if n in procs else 'emulator'].poll() is not None
            took = 0.0
            if external and controller_names:   # the simulated devices up and stepping,
                first = [n for n in managed if n not in controller_names]   # then the lab's
                took += activate_nodes(first, namespace, int(env['ROS_DOMAIN_ID']), gone)
                managed_later = [n for n in managed if n in controller_names]
                from pam_bench.bringup.external import await_external
                await_external(all_nodes, external, namespace, int(env['ROS_DOMAIN_ID']),
                               quiet)
            else:
                managed_later = managed
            for name in controller_names:
                start(name, node_cmd(name, pfile, namespace),
                      pipe=name == controller_names[0])
            took += activate_nodes(managed_later, namespace, int(env['ROS_DOMAIN_ID']), gone)
            line = (f'lifecycle: {", ".join(managed)} configured and active in {took:.2f} s'
                    if managed else '')
            log.write(line + '\n')
            if line and not quiet:
                print(line, flush=True)
            kills = [f for f in scene.faults if f.kind == 'node_kill']
            main = procs[controller_names[0] if controller_names else
                         'buses' if buses else 'emulator']
            if devices_only and not quiet:
                behind = (f' behind their buses ({driver_names[0]} and {driver_names[1]} '
                          'drive them)' if buses else ' in one process')
                print(f'devices {", ".join(device_names)} running on the wall clock{behind} '
                      f'(ROS_DOMAIN_ID {env["ROS_DOMAIN_ID"]}); Ctrl-C stops them',
                      flush=True)
            lines: Any = main.stdout
            if main.stdout is None or (buses and devices_only):   # its lines go to the log
                main.wait()
                lines = ()
            for line in lines:
                log.write(line)
                progress = line[line.find('[wall]'):] if '[wall]' in line else ''
                if kills and progress:                      # the run has started
                    threading.Thread(target=_kill_on_time, args=(kills, procs, device_names),
                                     daemon=True).start()
                    kills = []
                feed = procs['buses'].stdin if buses and progress else None
                if feed is not None and not feed.closed:    # the bus faults' clock starts
                    with contextlib.suppress(OSError):
                        feed.write('start\n')
                        feed.close()
                if not quiet and progress:       # the controller logs it: shown bare
                    print(progress, end='', flush=True)
                dead = [n for n, p in procs.items() if p.poll() is not None and p.returncode == 2]
                if dead:
                    break
            code = main.wait(timeout=10.0) if main.poll() is None and not dead else \
                (main.poll() or 0)
            dead = [n for n, p in procs.items() if p.poll() is not None and p.returncode == 2]
        except KeyboardInterrupt:
            code = 130
            dead = []
        except _NotStarted:
            code = procs['recorder'].wait()
            dead = ['recorder'] if code == 2 else []
        except LayoutError as exc:      # the buses did not come up, a node's lifecycle, or
            code, dead = 2, ['bring-up']  # an external device that did not meet the contract
            log.write(f'bring-up: error: {exc}\n')
        finally:
            write_end_state(settings, code)
            stop_processes(procs)
            log.flush()
            log.seek(0)
            node_log = log.read()
            log.close()
        stats = {}
        ran = [n for n in scene.nodes if not (buses and n in device_names) and
               n not in external] + driver_names
        for name in ran if started else []:
            path = os.path.join(tmp, f'{name}.json')
            try:
                with open(path, encoding='utf-8') as fh:
                    stats[name] = json.load(fh)
            except (OSError, ValueError):
                sys.stderr.write(f'warning: no statistics from {name}\n')
        bag = pathlib.Path(settings['recorder'].out_dir) if 'recorder' in settings else None
        if stats and bag is not None and bag.is_dir():
            (bag / STATS_FILE).write_text(json.dumps(stats, indent=1), encoding='utf-8')
            note_output_file(bag, STATS_FILE)
    wall = time.monotonic() - t0
    result = RunResult(code, 0, wall, wall, 1.0, f'wall clock, {wall:.1f} s', stats)
    if dead:
        result.code = 2
        result.summary = node_error(node_log) or f'node {dead[0]} stopped'
        sys.stderr.write(f'error: {result.summary}\n')
    elif code not in (0, 130):
        sys.stderr.write(node_log[-4000:])
    return result


def _kill_on_time(kills: list[Any], procs: dict[str, subprocess.Popen],
                  devices: list[str]) -> None:
    """node_kill faults: SIGKILL the process of each target ``at_s`` after the run started
    (called at the main controller's first progress line, within a tick of its start; a
    device lives in the emulator, which goes with it)."""
    t0 = time.monotonic()
    for f in sorted(kills, key=lambda f: f.at_s):
        time.sleep(max(0.0, t0 + f.at_s - time.monotonic()))
        name = f.target if f.target in procs else ('emulator' if f.target in devices else '')
        proc = procs.get(name)
        if proc is not None and proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
