"""Bring a scene up, run it, shut everything down: separate processes or one process.

Every run sets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and its own ``ROS_DOMAIN_ID`` (the
caller's when set, else one derived from the process id), so DDS stays on loopback and two
runs never see each other. Separate processes are stopped with SIGINT (then SIGTERM, SIGKILL
after a timeout), devices first and the recorder last, so the bag is always closed. A node
that stops at start-up (a bad parameter) ends the run at once with that node's one-line error.
The clock's ``RunSummary`` comes back as JSON (``summary_file``), not as text to parse.

On a wall clock (``wallclock``) there is no sim clock: the recorder starts first, then the
devices (by default composed in one emulator process, ``bringup.emulator``; with
``device_processes`` one process each), then the sequencer and the torque servo, every node
with ``lockstep: false``. The run ends when the sequencer or the servo exits (end of the
protocol, ``duration_s`` of the servo) or on Ctrl-C; the other nodes are then stopped, the
recorder last. The recorder records the topics a real bench has (no ``sim/`` ground truth,
which would double what crosses DDS). Every node writes its publish counts and tick periods
(``stats_file``), which come back in ``RunResult.stats`` with the recorder's delivery table.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any

import yaml

from pam_bench.bringup.errors import LayoutError
from pam_bench.config.nodes import NODES, controllers, devices
from pam_bench.config.scene import Scene, params_file
from pam_bench.sim.lockstep import RunSummary

__all__ = ['RunResult', 'ros_env', 'run_scene', 'node_error', 'write_params_file']


@dataclasses.dataclass
class RunResult:
    """Outcome of a run: exit code, steps, sim and wall seconds, lock-step rate (steps/s)."""

    code: int
    steps: int = 0
    sim_s: float = 0.0
    wall_s: float = 0.0
    rate: float = 0.0
    summary: str = ''
    # wall clock: per node; one process: 'deliveries' (messages to in-process subscriptions)
    stats: dict[str, Any] = dataclasses.field(default_factory=dict)


def ros_env(domain_id: int | None = None, discovery: str = 'LOCALHOST') -> dict[str, str]:
    """Environment for ROS processes of one run: loopback discovery (``SUBNET`` across
    network namespaces: ``netns``), a private domain."""
    env = dict(os.environ)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = discovery
    if domain_id is None:
        domain_id = int(env.get('ROS_DOMAIN_ID', '') or 1 + os.getpid() % 100)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env.setdefault('RCUTILS_COLORIZED_OUTPUT', '0')
    # One BLAS thread per node: many node processes share two cores, and BLAS thread pools
    # spinning against each other made a 4x4 matrix exponential 100x slower.
    for var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
        env[var] = '1'
    return env


def _die_with_parent() -> None:
    """In a node process: get SIGTERM when the runner dies, even by SIGKILL (Linux)."""
    try:
        import ctypes
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except OSError:
        pass


def _batch_child() -> None:
    """In a lock-step node process: ``_die_with_parent``, and the SCHED_BATCH policy.

    A lock-step run is throughput work: no deadline, only the exchanges per second. With
    more node processes than cores, the default policy lets every message wake-up preempt the
    running process, and each preemption is a context switch the exchange pays for; SCHED_BATCH
    (Linux, no privilege needed) keeps the nice level and drops that wake-up preemption
    (BENCHMARKS.md, Long runs, "Lock-step processes under SCHED_BATCH"). Wall-clock runs keep
    the default policy (or their SCHED_FIFO control loop).
    """
    _die_with_parent()
    try:
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
    except (AttributeError, OSError):
        pass


def _result(summary: RunSummary | None, code: int) -> RunResult:
    if summary is None:
        return RunResult(code)
    return RunResult(code, summary.steps, summary.sim_s, summary.wall_s, summary.rate,
                     summary.line())


def node_error(log: str) -> str:
    """The one-line error a node printed when it stopped (``nodes.process.run_node``), or ''."""
    for line in reversed(log.splitlines()):
        if ': error: ' in line:
            return line.strip()
    return ''


def _watch(procs: dict[str, subprocess.Popen], clock: subprocess.Popen,
           failed: list[str]) -> None:
    """Stop the clock when a node could not start (exit code 2: a bad parameter, its one
    line in the log); a node that dies later stalls the lock-step, and the clock says so."""
    while clock.poll() is None:
        for name, p in procs.items():
            if p.poll() is not None and p.returncode == 2:
                failed.append(name)
                if clock.poll() is None:
                    clock.send_signal(signal.SIGINT)
                return
        time.sleep(0.05)


def run_scene(scene: Scene, out_dir: str, seed: int = 0, realtime: bool = False,
              one_process: bool = False, domain_id: int | None = None,
              quiet: bool = False, wallclock: bool = False,
              device_processes: bool = False, devices_only: bool = False,
              settings: dict[str, Any] | None = None,
              netns: tuple[str, str] | None = None) -> RunResult:
    """Run ``scene``, recording into ``out_dir``; return the clock's summary. With
    ``devices_only`` (wall clock) only the simulated devices run, until Ctrl-C: a bench to
    point a lab's own controllers or ``check-drivers`` at. ``settings`` (node -> settings: the
    ones a bag recorded, ``--replay``) replace the scene's. ``netns`` (device namespace,
    other namespace) runs the simulated devices and the other nodes in two network
    namespaces, as on two hosts, with DDS discovery on their subnet (separate processes)."""
    settings = copy.deepcopy(settings) if settings else scene.settings(out_dir, seed, realtime)
    if 'recorder' in settings:
        from pam_bench.bringup.provenance import run_description
        rec = dataclasses.replace(settings['recorder'], out_dir=out_dir, run_yaml='',
                                  end_file='')
        settings['recorder'] = rec
        layout = ('wall clock' if wallclock else 'one process' if one_process
                  else 'separate processes')
        fd, end_file = tempfile.mkstemp(prefix='pam_bench_end_', suffix='.json')
        os.close(fd)
        os.unlink(end_file)
        run_yaml = yaml.safe_dump(run_description(scene, params_file(settings), seed, layout),
                                  sort_keys=False)
        settings['recorder'] = dataclasses.replace(rec, run_yaml=run_yaml, end_file=end_file)
    if scene.faults and not wallclock:
        raise LayoutError(f'scene {scene.name} injects faults: they run on the wall clock '
                         '(--wallclock)')
    if wallclock:
        if one_process:
            raise LayoutError('a wall-clock run composes the devices only (the emulator); '
                             'drop --one-process')
        return _run_wallclock(scene, settings, domain_id, quiet, device_processes, devices_only)
    if one_process:
        if netns:
            raise LayoutError('two namespaces need separate processes: drop --one-process')
        return _run_in_process(scene, settings, domain_id, quiet)
    return _run_processes(scene, settings, domain_id, quiet, netns)


def write_params_file(settings: dict[str, Any], path: str) -> None:
    """The settings as a ROS 2 params file (values as ROS holds them: ``nodes.params``)."""
    from pam_bench.models.params import flat_infos, get_path
    from pam_bench.nodes.params import ros_value
    out: dict[str, Any] = {}
    for name, st in settings.items():
        params: dict[str, Any] = {}
        for info in flat_infos(type(st)):
            here = params
            parts = info.name.split('.')
            for part in parts[:-1]:
                here = here.setdefault(part, {})
            here[parts[-1]] = ros_value(info, get_path(st, info.name))
        out[name] = {'ros__parameters': params}
    with open(path, 'w', encoding='utf-8') as fh:
        yaml.safe_dump(out, fh)


def _in_netns(name: str, netns: tuple[str, str] | None, cmd: list[str]) -> list[str]:
    """``cmd`` run in the device namespace (simulated devices) or the other one."""
    if netns is None:
        return cmd
    return ['ip', 'netns', 'exec', netns[0] if devices([name]) else netns[1], *cmd]


def _node_cmd(name: str, pfile: str) -> list[str]:
    return [sys.executable, '-m', NODES[name].module, '--ros-args', '-r', f'__node:={name}',
            '--params-file', pfile]


def _run_processes(scene: Scene, settings: dict[str, Any], domain_id: int | None,
                   quiet: bool, netns: tuple[str, str] | None = None) -> RunResult:
    env = ros_env(domain_id, 'SUBNET' if netns else 'LOCALHOST')
    procs: dict[str, subprocess.Popen] = {}
    failed: list[str] = []
    with tempfile.TemporaryDirectory(prefix='pam_bench_') as tmp:
        pfile = os.path.join(tmp, 'params.yaml')
        summary_file = os.path.join(tmp, 'summary.json')
        settings['sim_clock'] = dataclasses.replace(settings['sim_clock'],
                                                    summary_file=summary_file)
        write_params_file(settings, pfile)
        log = open(os.path.join(tmp, 'nodes.log'), 'w+', encoding='utf-8')
        paced = settings['sim_clock'].realtime
        child = _die_with_parent if paced else _batch_child     # paced: wake-ups matter
        try:
            order = [n for n in scene.nodes if n != 'recorder']
            if 'recorder' in scene.nodes:
                order.insert(0, 'recorder')
            for name in order:
                procs[name] = subprocess.Popen(_in_netns(name, netns, _node_cmd(name, pfile)),
                                               env=env, stdout=log, stderr=subprocess.STDOUT,
                                               preexec_fn=child)
            clock = subprocess.Popen(_in_netns('sim_clock', netns,
                                               _node_cmd('sim_clock', pfile)),
                env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                preexec_fn=child)
            watcher = threading.Thread(target=_watch, args=(dict(procs), clock, failed),
                                       daemon=True)
            watcher.start()
            procs = {'sim_clock': clock, **procs}
            lines = []
            assert clock.stdout is not None
            for line in clock.stdout:
                lines.append(line)
                if not quiet and (line.startswith('[sim') or line.startswith('lock-step:')):
                    print(line, end='', flush=True)
            code = clock.wait()
            dead = [n for n, p in procs.items() if n != 'sim_clock' and p.poll() is not None]
        finally:
            _write_end(settings, code if 'code' in locals() else None)
            _stop(procs)
            log.flush()
            log.seek(0)
            node_log = log.read()
            log.close()
        summary = None
        if os.path.exists(summary_file):
            with open(summary_file, encoding='utf-8') as fh:
                summary = RunSummary.from_json(fh.read())
        result = _result(summary, code)
        if failed:
            result.code = 2
            result.summary = node_error(node_log) or f'node {failed[0]} stopped'
            sys.stderr.write(f'error: {result.summary}\n')
        elif code != 0 or dead:
            result.code = code or 5
            sys.stderr.write(''.join(lines)[-3000:] + node_log[-4000:])
    return result


def _run_wallclock(scene: Scene, settings: dict[str, Any], domain_id: int | None, quiet: bool,
                   device_processes: bool, devices_only: bool = False) -> RunResult:
    import json

    env = ros_env(domain_id)
    device_names = devices(scene.nodes)
    controller_names = controllers(scene.nodes)
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
        rep = dataclasses.replace
        settings = {k: v for k, v in settings.items() if k in scene.nodes}   # no clock
        for name in scene.nodes:
            settings[name] = rep(settings[name], lockstep=False,
                                 stats_file=os.path.join(tmp, f'{name}.json'))
        if 'torque_servo' in settings:
            settings['torque_servo'] = rep(settings['torque_servo'], duration_s=scene.duration_s)
        for target in {f.target for f in scene.faults if f.kind != 'node_kill'}:
            settings[target] = rep(settings[target], faults_yaml=yaml.safe_dump(
                [dataclasses.asdict(f) for f in scene.faults if f.target == target]))
        for name in controller_names:      # nothing a controller publishes goes unrecorded
            settings[name] = rep(settings[name], await_recorder='recorder' in scene.nodes)
        if 'recorder' in settings:          # what a real bench has: no sim/ ground truth
            rec = settings['recorder']
            settings['recorder'] = rep(rec, step_topics=[
                t for t in rec.step_topics if not t.startswith('/sim/')])
        pfile = os.path.join(tmp, 'params.yaml')
        write_params_file(settings, pfile)
        log = open(os.path.join(tmp, 'nodes.log'), 'w+', encoding='utf-8')

        def start(name: str, cmd: list[str], pipe: bool = False) -> subprocess.Popen:
            procs[name] = subprocess.Popen(
                cmd, env=env, stdout=subprocess.PIPE if pipe else log,
                stderr=subprocess.STDOUT, text=True, preexec_fn=_die_with_parent)
            return procs[name]

        try:
            if 'recorder' in scene.nodes:
                rec = start('recorder', _node_cmd('recorder', pfile), pipe=True)
                assert rec.stdout is not None
                for line in rec.stdout:      # wait until it has subscribed to its topics
                    log.write(line)
                    if line.startswith('recorder: recording') or rec.poll() is not None:
                        break
                threading.Thread(target=_copy, args=(rec.stdout, log), daemon=True).start()
            if device_processes:
                for name in device_names:
                    start(name, _node_cmd(name, pfile))
            elif device_names:
                start('emulator', [sys.executable, '-m', 'pam_bench.bringup.emulator', pfile,
                                   *device_names])
            for name in controller_names:
                start(name, _node_cmd(name, pfile), pipe=name == controller_names[0])
            kills = [f for f in scene.faults if f.kind == 'node_kill']
            main = procs[controller_names[0] if controller_names else 'emulator']
            if devices_only and not quiet:
                print(f'devices {", ".join(device_names)} running on the wall clock in one '
                      f'process (ROS_DOMAIN_ID {env["ROS_DOMAIN_ID"]}); Ctrl-C stops them',
                      flush=True)
            if main.stdout is None:
                main.wait()
            for line in main.stdout or ():
                log.write(line)
                if kills and line.startswith('[wall]'):     # the run has started
                    threading.Thread(target=_kill_on_time, args=(kills, procs, device_names),
                                     daemon=True).start()
                    kills = []
                if not quiet and line.startswith('[wall'):
                    print(line, end='', flush=True)
                dead = [n for n, p in procs.items() if p.poll() is not None and p.returncode == 2]
                if dead:
                    break
            code = main.wait(timeout=10.0) if main.poll() is None and not dead else \
                (main.poll() or 0)
            dead = [n for n, p in procs.items() if p.poll() is not None and p.returncode == 2]
        except KeyboardInterrupt:
            code = 130
            dead = []
        finally:
            _write_end(settings, code)
            _stop(procs)
            log.flush()
            log.seek(0)
            node_log = log.read()
            log.close()
        stats = {}
        for name in scene.nodes:
            path = os.path.join(tmp, f'{name}.json')
            try:
                with open(path, encoding='utf-8') as fh:
                    stats[name] = json.load(fh)
            except (OSError, ValueError):
                sys.stderr.write(f'warning: no statistics from {name}\n')
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


def _write_end(settings: dict[str, Any], code: int | None) -> None:
    """Tell the recorder how the run ended (``provenance.write_end``) before it is stopped."""
    from pam_bench.bringup.provenance import write_end
    rec = settings.get('recorder')
    path = rec.end_file if rec is not None else ''
    try:
        write_end(path, code)
    except OSError as exc:
        sys.stderr.write(f'warning: end state not written: {exc}\n')


def clock_done(nodes: list[Any], scene: Scene) -> bool:
    """In one process: whether the sim clock ended the run (it has its summary)."""
    clock = nodes[-1] if nodes and len(nodes) == len(scene.nodes) + 1 else None
    return getattr(clock, 'summary', None) is not None


def _copy(src: Any, dst: Any) -> None:
    for line in src:
        dst.write(line)


def _stop(procs: dict[str, subprocess.Popen]) -> None:
    """SIGINT the clock and the devices, then the recorder; escalate after timeouts."""
    devices = [n for n in procs if n != 'recorder']
    groups = [devices] + ([['recorder']] if 'recorder' in procs else [])
    for group in groups:
        for n in group:
            if procs[n].poll() is None:
                procs[n].send_signal(signal.SIGINT)
        for n in group:
            for sig, wait in ((None, 10.0), (signal.SIGTERM, 5.0), (signal.SIGKILL, 5.0)):
                if sig is not None and procs[n].poll() is None:
                    procs[n].send_signal(sig)
                try:
                    procs[n].wait(timeout=wait)
                    break
                except subprocess.TimeoutExpired:
                    continue


def _run_in_process(scene: Scene, settings: dict[str, Any], domain_id: int | None,
                    quiet: bool) -> RunResult:
    import contextlib
    import importlib
    import io

    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.executors import SingleThreadedExecutor

    from pam_bench.models.errors import ParameterError
    from pam_bench.nodes import intra
    from pam_bench.nodes.params import overrides_of
    from pam_bench.nodes.process import fail_line, reject_undeclared
    from pam_bench.nodes.profiling import profiled

    env = ros_env(domain_id)
    os.environ['ROS_DOMAIN_ID'] = env['ROS_DOMAIN_ID']
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    nodes = []
    code = 0
    buf = io.StringIO()
    t0 = time.monotonic()
    bus = intra.activate()
    try:
        for name in ['recorder'] * ('recorder' in scene.nodes) + [
                n for n in scene.nodes if n != 'recorder'] + ['sim_clock']:
            t = NODES[name]
            cls = getattr(importlib.import_module(t.module), t.cls)
            overrides = overrides_of(settings[name])
            extra = {'lean': True} if name == 'sim_clock' else {}    # polled by the loop
            try:
                node = cls(name, context=context, parameter_overrides=overrides, **extra)
            except ParameterException as exc:
                raise ParameterError(fail_line(name, exc)) from None
            nodes.append(node)
            reject_undeclared(node, overrides)
            executor.add_node(node)
        with contextlib.redirect_stdout(buf if quiet else sys.stdout):
            try:
                with profiled('composed'):
                    intra.spin_composed(bus, nodes, executor)
            except SystemExit as exc:
                code = int(exc.code or 0)
    finally:
        intra.deactivate()
        _write_end(settings, code if code or clock_done(nodes, scene) else None)
        clock = nodes[-1] if nodes and len(nodes) == len(scene.nodes) + 1 else None
        for node in nodes:
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
    summary = getattr(clock, 'summary', None)
    if summary is None:                 # interrupted before the clock finished
        wall = time.monotonic() - t0
        k = getattr(clock, 'k', 0)
        return RunResult(code, k, k * getattr(clock, 'step_s', 0.0), wall, k / wall)
    res = _result(summary, code)
    res.stats['deliveries'] = bus.deliveries      # what separate processes would send by DDS
    return res


def flatten(d: dict[str, Any], prefix: str = '') -> dict[str, Any]:
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flatten(v, f'{prefix}{k}.'))
        else:
            out[f'{prefix}{k}'] = v
    return out
