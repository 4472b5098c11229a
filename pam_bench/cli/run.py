"""Verbs that run the bench: run, record, emulate, check-drivers, params."""

from __future__ import annotations

import argparse
import pathlib
import sys
from typing import Any

from pam_bench.cli.errors import UsageError
from pam_bench.cli.json_out import dumps
from pam_bench.cli.numbers import integer, number, out_path
from pam_bench.vocabulary.errors import shorten

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('run', help='run a scene and record a bag')
    p.add_argument('scene', nargs='?', help='scene name in config/scenes or a path to a scene '
                   'file')
    p.add_argument('--replay', metavar='BAG', help="run a bag's own scene again with its "
                   'recorded parameters, seed and layout (into --out)')
    p.add_argument('--out', type=out_path, help='bag directory (default bags/SCENE, replaced)')
    p.add_argument('--overwrite', action='store_true', help='replace --out if it exists')
    p.add_argument('--params', metavar='FILE', help='parameter overlay (pam-bench calibrate '
                   "--out): over config/bench.yaml, under the scene's own parameters")
    p.add_argument('--set', action='append', default=[], metavar='PATH=VALUE',
                   help='set one setting by its path over the scene, e.g. '
                   'muscle_1.muscle.gain_exponent=1.4 (repeatable; pam-bench params lists them)')
    p.add_argument('--seed', type=integer(0, 2**31 - 1), default=0,
                   help='seed of the sensor noise')
    p.add_argument('--realtime', action='store_true', help='pace sim time to the wall clock')
    p.add_argument('--processes', action='store_true', help='lock-step: every node in its own '
                   'process, as beside drivers (default: the nodes composed in one process on '
                   'the intra-process bus)')
    p.add_argument('--resume', metavar='BAG', help='bag of an interrupted run of this scene: '
                   'start at the first reading it lacks (into a new --out)')
    p.add_argument('--wallclock', action='store_true', help='run on the wall clock as on a '
                   'real bench: devices free-running in one emulator process, controllers and '
                   'recorder in their own')
    p.add_argument('--netns', metavar='DEVICES_NS:OTHER_NS', help='run the simulated devices '
                   'in one network namespace and the other nodes in another, as on two hosts '
                   '(lock-step, separate processes; README, "Two hosts")')
    p.add_argument('--device-processes', action='store_true', help='with --wallclock: each '
                   'device in its own process instead of the emulator')
    add_bag_options(p)
    add_live_options(p, '--live', 'serve the recorded topics to Foxglove during the run on '
                     'ws://127.0.0.1:PORT (README, "Watching a run")')
    add_namespace_option(p, 'with --wallclock: run every node in this ROS namespace, so that '
                         'two benches share a domain without mixing')
    add_buses_option(p, 'with --wallclock: serve the simulated devices behind a Modbus TCP '
                     'DAQ and a CANopen CiA 402 drive and run the drivers daq_modbus and '
                     'servo_canopen in their place (README, "Behind real buses")')
    add_external_option(p, 'with --wallclock: leave these devices to your own drivers: the '
                        'others are simulated, and the protocol starts once these meet the '
                        'driver contract (docs/drivers.md)')
    p.set_defaults(func=_cmd_run)
    p = sub.add_parser('record', help='record topics of a running graph on the wall clock '
                       '(like ros2 bag record), until Ctrl-C')
    p.add_argument('topics', nargs='*', help='topic names (types are discovered)')
    p.add_argument('--all', action='store_true', help='every topic that appears')
    p.add_argument('--out', type=out_path, required=True, help='bag directory to create')
    add_bag_options(p)
    p.set_defaults(func=_cmd_record)
    p = sub.add_parser('live', help='serve the topics of a running bench to Foxglove (join a '
                       'running graph), until Ctrl-C')
    p.add_argument('scene', nargs='?', default='demo', help="scene whose recorder's topics to "
                   'serve (default demo)')
    add_live_options(p, '--port', 'TCP port of the server')
    add_namespace_option(p, 'the namespace of the bench to serve')
    p.set_defaults(func=_cmd_live)
    p = sub.add_parser('emulate', help="run only a scene's simulated devices on the wall "
                       'clock, until Ctrl-C (a bench for your own controllers)')
    p.add_argument('scene', nargs='?', default='demo')
    p.add_argument('--seed', type=integer(0, 2**31 - 1), default=0,
                   help='seed of the sensor noise')
    add_namespace_option(p, 'run the devices in this ROS namespace')
    add_buses_option(p, 'serve the devices behind a Modbus TCP DAQ on 127.0.0.1 and a CiA 402 '
                     'drive on a CAN hub, with the drivers daq_modbus and servo_canopen')
    add_external_option(p, 'leave these devices to your own drivers: only the others run')
    p.set_defaults(func=_cmd_emulate)
    p = sub.add_parser('check-drivers', help='join a running bench and check that its drivers '
                       'meet the contract (docs/drivers.md)')
    p.add_argument('scene', nargs='?', default='demo', help='scene whose controllers will read '
                   'the drivers (default demo: the sequencer)')
    p.add_argument('--duration', type=number(0, 3600, 's', True), default=3.0,
                   help='listening time, s')
    add_namespace_option(p, 'the namespace of the bench whose drivers to check')
    p.set_defaults(func=_cmd_check_drivers)
    p = sub.add_parser('params', help="every setting of a scene's nodes: path, value, unit, "
                       'range and meaning (what --set, overlays and sweeps address)')
    p.add_argument('scene', nargs='?', default='demo')
    p.add_argument('--node', action='append', help='only this node (repeatable)')
    p.add_argument('--json', action='store_true')
    p.add_argument('--ros-yaml', nargs='?', const='-', metavar='FILE',
                   help="write the nodes' settings on a wall clock (as run --wallclock starts "
                   'them) as an rcl params file, keyed /**/NODE so that it applies in any '
                   'namespace: to FILE, or stdout (for nodes started by hand: README)')
    p.add_argument('--overwrite', action='store_true', help='replace a --ros-yaml FILE '
                   'pam-bench wrote')
    p.set_defaults(func=_cmd_params)


def _namespace(text: str) -> str:
    """A ROS namespace: tokens of letters, digits and underscores (not starting with a
    digit) joined by '/'; made absolute."""
    import re
    ns = '/' + text.strip().strip('/')
    if ns != '/' and not re.fullmatch(r'(/[A-Za-z_][A-Za-z0-9_]*)+', ns):
        raise argparse.ArgumentTypeError(f'{shorten(text)} is not a ROS namespace (tokens '
                                         'of letters, digits and _, e.g. /bench_a)')
    return '' if ns == '/' else ns


def add_buses_option(p: argparse.ArgumentParser, text: str) -> None:
    """``--buses [MAP]``: the devices behind field buses, the DAQ's register map MAP."""
    p.add_argument('--buses', nargs='?', const='daq_generic', default='', metavar='MAP',
                   help=f'{text}; MAP: the register map (default daq_generic)')


def add_external_option(p: argparse.ArgumentParser, text: str) -> None:
    """``--external NAME ...``: devices a lab's own drivers stand in for."""
    p.add_argument('--external', nargs='+', action='extend', default=[], metavar='DEVICE',
                   help=text)


def add_namespace_option(p: argparse.ArgumentParser, text: str) -> None:
    """``--namespace NS``: where the bench's nodes run (default: the root)."""
    p.add_argument('--namespace', type=_namespace, default='', metavar='NS', help=text)


def _live_setting(name: str, convert: Any) -> Any:
    """An argparse type for the live view's setting ``name``: ``convert`` the text, then check
    it against the range ``LiveViewSettings`` declares (its one owner)."""
    def parse(text: str) -> Any:
        from pam_bench.config.settings import LiveViewSettings
        from pam_bench.vocabulary.errors import ParameterError
        from pam_bench.vocabulary.params import with_path
        try:
            value = convert(text)
            with_path(LiveViewSettings(), name, value)
        except (ValueError, ParameterError) as exc:
            raise argparse.ArgumentTypeError(f'{text!r}: {exc}') from None
        return value
    return parse


def add_live_options(p: argparse.ArgumentParser, flag: str, text: str) -> None:
    """The live view's options (``config.settings.LiveViewSettings``, whose defaults and ranges
    they take)."""
    from pam_bench.config.settings import LiveViewSettings
    d = LiveViewSettings()
    p.add_argument(flag, nargs='?', const=d.port, default=None, metavar='PORT',
                   type=_live_setting('port', int), help=f'{text} (default {d.port})')
    p.add_argument('--live-host', metavar='HOST', help=f'address the live view binds (default '
                   f'{d.host}, this machine only; 0.0.0.0 opens it to the network)')
    p.add_argument('--live-rate', metavar='HZ', type=_live_setting('max_rate_hz', float),
                   help=f'send each 1 kHz topic at most this often (default {d.max_rate_hz:g}; '
                   '0: every message); points and status always whole')


def live_settings(args: argparse.Namespace, port: int | None) -> Any:
    """The live view's settings of the command line."""
    from pam_bench.bringup.live import with_port
    from pam_bench.config.settings import LiveViewSettings
    return with_port(LiveViewSettings(), port, args.live_host, args.live_rate, [])


def add_bag_options(p: argparse.ArgumentParser) -> None:
    """The recorder's file options, as rosbag2's."""
    p.add_argument('--max-bag-size', metavar='SIZE', type=parse_size, help='start a new file of '
                   'the bag past this size: bytes, or 500M, 2G, ... (default 900M; 0: never)')
    p.add_argument('--max-bag-duration', metavar='DURATION', type=parse_duration,
                   help='start a new file of the bag once it spans this long: seconds, or 90s, '
                   '30m, 1h, ... (default: never)')
    p.add_argument('--no-compress', action='store_true', help='write the MCAP chunks '
                   'uncompressed (default zstd)')


_SIZES = {'': 1, 'b': 1, 'k': 10**3, 'kb': 10**3, 'm': 10**6, 'mb': 10**6, 'g': 10**9,
          'gb': 10**9, 'ki': 2**10, 'kib': 2**10, 'mi': 2**20, 'mib': 2**20, 'gi': 2**30,
          'gib': 2**30}
_DURATIONS = {'': 1.0, 's': 1.0, 'm': 60.0, 'min': 60.0, 'h': 3600.0}


def _number_unit(text: str, units: dict[str, Any], what: str, example: str) -> float:
    import math
    import re
    m = re.fullmatch(r'\s*([0-9.]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*', text)
    unit = m.group(2).lower() if m else ''
    try:
        value = float(m.group(1)) if m else math.nan
    except ValueError:
        value = math.nan
    if not m or unit not in units or not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f'{text!r} is not a {what} (write e.g. {example})')
    return value * units[unit]


def _recorder_range(name: str, value: float) -> None:
    """Check ``value`` against the recorder's setting ``name`` (its one owner)."""
    from pam_bench.config.settings import RecorderSettings
    from pam_bench.vocabulary.errors import ParameterError
    from pam_bench.vocabulary.params import with_path
    try:
        with_path(RecorderSettings(), name, value)
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc).replace('parameter ', '', 1)) from None


def parse_size(text: str) -> int:
    """``--max-bag-size``: ``1000000``, ``500M``, ``1.5G``, ``512MiB`` -> bytes (0: never)."""
    value = round(_number_unit(text, _SIZES, 'size', '500M, 2G or 1000000'))
    _recorder_range('max_bag_size_bytes', value)
    return value


def parse_duration(text: str) -> float:
    """``--max-bag-duration``: ``600``, ``90s``, ``30m``, ``1h`` -> seconds (0: never)."""
    value = _number_unit(text, _DURATIONS, 'duration', '90s, 30m or 1h')
    _recorder_range('max_bag_duration_s', value)
    return value


def apply_bag_options(scene: Any, args: argparse.Namespace) -> None:
    """The recorder settings of ``--max-bag-size``, ``--max-bag-duration``, ``--no-compress``."""
    if args.max_bag_size is not None:
        scene.set('recorder.max_bag_size_bytes', args.max_bag_size)
    if args.max_bag_duration is not None:
        scene.set('recorder.max_bag_duration_s', args.max_bag_duration)
    if args.no_compress:
        scene.set('recorder.compress', False)


def parse_value(text: str) -> Any:
    """A ``--set`` value as YAML reads it (numbers, true/false, lists, strings); text that is
    not YAML stays a string.

    Raises:
        InputError: an alias bomb, a duplicate key or a value longer than the YAML limit.
    """
    from pam_bench.vocabulary.errors import InputError
    from pam_bench.vocabulary.yaml_io import load_yaml
    try:
        return load_yaml(text, '--set value')
    except InputError as exc:
        if 'not valid YAML' in str(exc):
            return text
        raise


def load_with_sets(name: str, sets: list[str]) -> Any:
    """The scene ``name`` with every ``PATH=VALUE`` of ``sets`` applied.

    Raises:
        UsageError: a ``--set`` without '='.
        ConfigError: an unknown scene or setting, a bad value (named).
    """
    from pam_bench.config.scene import load_scene
    scene = load_scene(name)
    for item in sets:
        path, eq, value = item.partition('=')
        if not eq:
            raise UsageError(f'--set {shorten(item)}: write PATH=VALUE, e.g. '
                             'muscle_1.muscle.gain_exponent=1.4')
        scene.set(path.strip(), parse_value(value))
    return scene


def _replayed(args: argparse.Namespace) -> tuple[Any, dict[str, Any] | None]:
    """The scene and settings a bag recorded (``run --replay BAG``)."""
    import tempfile

    from pam_bench.bags.baginfo import run_of_bag
    from pam_bench.bags.errors import BagError
    from pam_bench.config.scene import load_scene, settings_of_params_file
    from pam_bench.vocabulary.run import Layout
    try:
        run = run_of_bag(args.replay)
    except BagError as exc:
        raise BagError(f'cannot replay: {exc}') from None
    with tempfile.TemporaryDirectory(prefix='pam_bench_replay_') as tmp:
        path = pathlib.Path(tmp) / f'{run["scene"]}.yaml'
        path.write_text(run['scene_text'], encoding='utf-8')
        scene = load_scene(str(path))
    args.seed = int(run['seed'])
    layout = str(run.get('layout', ''))
    try:
        args.processes = Layout.parse(layout) is Layout.PROCESSES
        args.wallclock = Layout.parse(layout) is Layout.WALL_CLOCK
    except ValueError:
        raise BagError(f'cannot replay: {args.replay} names an unknown layout '
                       f'{shorten(layout)}') from None
    print(f'replaying {args.replay}: scene {run["scene"]}, seed {args.seed}, {layout}, '
          f'recorded at commit {run["commit"][:12]}' + (' (dirty)' if run.get('dirty') else ''))
    params = run.get('parameters')
    return scene, (settings_of_params_file(params, f'{args.replay}: recorded parameters')
                   if params else None)


def _resume_start(scene: Any, bag: str) -> tuple[int, int]:
    """The reading to resume ``scene`` at from ``bag`` (a bag of this scene and protocol).

    Raises:
        BagError: unreadable, of another scene or protocol, or without readings.
    """
    from pam_bench.bags.baginfo import run_of_bag
    from pam_bench.bags.errors import BagError
    from pam_bench.bringup.resume import resume_reading
    try:
        run = run_of_bag(bag)
        seq = (run.get('parameters') or {}).get('sequencer', {}).get('ros__parameters', {})
        if run.get('scene') != scene.name or seq.get('protocol') != scene.protocol:
            raise BagError(f"a bag of scene {run.get('scene')!r} (protocol "
                           f"{seq.get('protocol')!r}), not of {scene.name!r} ({scene.protocol!r})")
        return resume_reading(scene, bag)
    except BagError as exc:
        raise BagError(f'cannot resume from {bag}: {exc}') from None


def _cmd_run(args: argparse.Namespace) -> int:
    from pam_bench.bags.splitwriter import check_room
    from pam_bench.bringup.runner import run_scene
    from pam_bench.vocabulary.outputs import check_output, clear_output
    from pam_bench.vocabulary.run import Layout, RunOptions
    settings = None
    if args.replay:
        if args.scene or not args.out:
            raise UsageError('--replay BAG takes no scene and needs --out')
        scene, settings = _replayed(args)
    elif not args.scene:
        raise UsageError('name a scene (or --replay BAG)')
    else:
        scene = load_with_sets(args.scene, [])
    if args.params:
        from pam_bench.config.scene import apply_overlay
        apply_overlay(scene, args.params)
    for item in args.set:
        path, eq, value = item.partition('=')
        if not eq:
            raise UsageError(f'--set {shorten(item)}: write PATH=VALUE')
        scene.set(path.strip(), parse_value(value))
    apply_bag_options(scene, args)
    if args.wallclock and (args.processes or args.realtime):
        raise UsageError('--wallclock runs the devices in the emulator on the wall clock: drop '
                         '--processes and --realtime')
    if args.external and not args.wallclock:
        raise UsageError('--external runs beside your devices on the wall clock: add '
                         '--wallclock')
    if args.external:
        from pam_bench.bringup.external import check_external
        check_external(scene.name, scene.nodes, args.external, args.buses)
    if (args.buses or args.namespace) and not args.wallclock:
        raise UsageError(f'{"--buses" if args.buses else "--namespace"} runs the bench on the '
                         'wall clock: add --wallclock')
    if args.buses:
        from pam_bench.buses.register_map import load_register_map
        load_register_map(args.buses)           # a bad map: one line, before anything
    out = pathlib.Path(args.out if args.out is not None else f'bags/{scene.name}')
    inputs = [p for p in (args.resume, args.replay, args.params) if p]
    real = check_output(out, 'pam-bench run', args.overwrite, inputs, bag=True)
    if args.resume:
        start, total = _resume_start(scene, args.resume)
        if start >= total:
            print(f'{args.resume} holds every reading of {scene.protocol}: nothing to resume')
            return 0
        scene.set('sequencer.resume_from_reading', start)
    rec = scene.settings().get('recorder')
    check_room(real, int(rec.min_free_bytes) if rec is not None else 0)
    # every check has passed: nothing was written or removed before this line
    clear_output(real)
    if args.resume:
        print(f'resuming {scene.protocol} at reading {start} of {total} (the first one '
              f'{args.resume} lacks)')
    print(f'scene {scene.name}: {scene.description}\n  exchange step {scene.exchange_step_s} s, '
          f'nodes {", ".join(scene.nodes)}, bag {out}', flush=True)
    from pam_bench.config.scene import law_notes
    for note in law_notes(scene.settings()):
        print(f'  {note}', flush=True)
    try:
        layout = (Layout.WALL_CLOCK if args.wallclock else Layout.PROCESSES if args.processes
                  else Layout.COMPOSED)
        res = run_scene(scene, str(real), RunOptions(
            seed=args.seed, layout=layout, realtime=args.realtime,
            device_processes=args.device_processes, settings=settings,
            netns=tuple(args.netns.split(':', 1)) if args.netns else None,
            namespace=args.namespace, buses=args.buses, external=tuple(args.external),
            live=live_settings(args, args.live) if args.live is not None else None))
        code = res.code
    except KeyboardInterrupt:
        print(_interrupted(out), file=sys.stderr)
        return 130
    if code == 130:
        if args.wallclock and res.stats:
            print_wall_stats(res.stats)
        print(_interrupted(out), file=sys.stderr)
        return 130
    if res.code != 0:
        print(f'error: scene {scene.name} failed (exit code {res.code})', file=sys.stderr)
        return res.code
    if args.wallclock:
        print_wall_stats(res.stats)
        print(f'done: {res.wall_s:.1f} s on the wall clock; bag in {out}')
        return 0
    print(f'done: {res.steps} exchange steps, {res.sim_s:.2f} s sim in {res.wall_s:.2f} s wall '
          f'({res.rate:.0f} steps/s, x{res.sim_s / res.wall_s if res.wall_s else 0:.1f} real '
          f'time); bag in {out}')
    return 0


def _interrupted(out: pathlib.Path) -> str:
    """What Ctrl-C says: where the bag was closed, or that none was made yet."""
    from pam_bench.vocabulary.outputs import is_bag_folder
    if is_bag_folder(out):
        return f'interrupted: nodes stopped, bag closed in {out}'
    return 'interrupted before the bag was made: nodes stopped, nothing written'


def print_wall_stats(stats: dict[str, Any]) -> None:
    """Period statistics per ticking node and the recorder's delivery table."""
    from pam_bench.analysis.delivery import delivery_table, format_delivery
    for name, st in stats.items():
        per = st.get('periods')
        if per:
            print(f'{name:14s} period mean {per["mean_s"] * 1e3:.3f} ms, p50 '
                  f'{per["p50_s"] * 1e3:.3f}, p99 {per["p99_s"] * 1e3:.3f}, max '
                  f'{per["max_s"] * 1e3:.3f} ms (at {per["max_at_s"]:.1f} s), late '
                  f'{per["late_share"] * 100:.2f} %, rate {1.0 / per["mean_s"]:.1f} Hz'
                  + (f', {st["dropped_ticks"]} ticks dropped' if st.get('dropped_ticks')
                     else ''))
    if 'recorder' in stats:
        print(format_delivery(delivery_table(
            {k: v for k, v in stats.items() if k != 'recorder'}, stats['recorder'])))


def _cmd_record(args: argparse.Namespace) -> int:
    from pam_bench.nodes.recorder import record
    if not args.topics and not args.all:
        raise UsageError('name the topics to record or give --all')
    from pam_bench.vocabulary.outputs import check_output
    out = check_output(args.out, 'pam-bench record', False, bag=True)
    if out.exists():
        raise UsageError(f'{args.out} exists: pick a new folder for the bag')
    return record(str(out), args.topics, args.all, compress=not args.no_compress,
                  max_bytes=args.max_bag_size, max_duration_s=args.max_bag_duration)


def _cmd_live(args: argparse.Namespace) -> int:
    import dataclasses

    from pam_bench.bringup.live import live_topics, live_view
    scene = load_with_sets(args.scene, [])
    live = live_settings(args, args.port)
    live = dataclasses.replace(live, topics=live_topics(scene.settings('', 0, False)))
    try:
        with live_view(live, namespace=args.namespace) as proc:
            assert proc is not None
            proc.wait()
    except KeyboardInterrupt:
        return 0
    return 0


def _cmd_emulate(args: argparse.Namespace) -> int:
    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    from pam_bench.vocabulary.run import Layout, RunOptions
    res = run_scene(load_scene(args.scene), '',
                    RunOptions(layout=Layout.WALL_CLOCK, seed=args.seed, devices_only=True,
                               namespace=args.namespace, buses=args.buses,
                               external=tuple(args.external)))
    return 0 if res.code in (0, 130) else res.code


def _cmd_check_drivers(args: argparse.Namespace) -> int:
    from pam_bench.config.nodes import controllers
    from pam_bench.config.scene import load_scene
    from pam_bench.nodes.driver_probe import probe_drivers
    names = controllers(load_scene(args.scene).nodes)
    if not names:
        raise UsageError(f'scene {args.scene} has no sequencer or torque servo: nothing reads '
                         'drivers')
    verdicts = probe_drivers(names, args.duration, namespace=args.namespace)
    print(f'{"topic":26s} {"expected":44s} {"seen":36s} result')
    for v in verdicts:
        print(f'{v.topic:26s} {v.expected:44s} {v.seen:36s} '
              + ('pass' if v.ok else 'FAIL') + (f': {v.reason}' if v.reason else ''))
    failed = [v for v in verdicts if not v.ok]
    print(f'{len(verdicts) - len(failed)} of {len(verdicts)} pass')
    return 1 if failed else 0


def _ros_yaml(scene: Any, settings: dict[str, Any], only: list[str] | None, path: str,
              overwrite: bool) -> int:
    """``params --ros-yaml``: the wall-clock settings of the scene's nodes (or ``only``) as
    an rcl params file on stdout ('-') or in ``path`` (a file of pam-bench's own with
    ``overwrite``)."""
    import yaml

    from pam_bench.bringup.common import ros_params
    from pam_bench.bringup.wallclock import wall_settings
    from pam_bench.vocabulary.outputs import check_output_file, write_output_file
    wall = wall_settings(scene, settings)
    text = yaml.safe_dump(ros_params({k: v for k, v in wall.items()
                                      if not only or k in only}), sort_keys=False)
    if path == '-':
        print(text, end='')
        return 0
    check_output_file(path, 'params --ros-yaml', overwrite)
    write_output_file(path, 'params --ros-yaml', text)
    print(f'wrote {path}: nodes {", ".join(k for k in wall if not only or k in only)}')
    return 0


def _cmd_params(args: argparse.Namespace) -> int:
    from pam_bench.config.scene import load_scene
    from pam_bench.vocabulary.params import flat_infos, get_path
    scene = load_scene(args.scene)
    settings = scene.settings()
    unknown = [n for n in args.node or [] if n not in settings]
    if unknown:
        raise UsageError(f'scene {scene.name} has no node {unknown[0]!r} (nodes: '
                         f'{", ".join(settings)})')
    if args.ros_yaml:
        return _ros_yaml(scene, settings, args.node, args.ros_yaml, args.overwrite)
    rows = []
    for name, st in settings.items():
        if args.node and name not in args.node:
            continue
        for info in flat_infos(type(st)):
            value = get_path(st, info.name)
            rows.append({'path': f'{name}.{info.name}', 'value': value,
                         'default': info.default, 'unit': info.unit, 'low': info.low,
                         'high': info.high, 'choices': list(info.choices), 'text': info.text,
                         'tunable': info.tunable})
    if args.json:
        print(dumps(rows))
        return 0
    for r in rows:
        rng = (f" [{r['low']}, {r['high']}]" if r['low'] is not None or r['high'] is not None
               else f" {{{', '.join(r['choices'])}}}" if r['choices'] else '')
        mark = ('' if r['value'] == r['default'] else f"  (default {r['default']})") + \
            ('  [tunable while running]' if r['tunable'] else '')
        print(f"{r['path']:50s} {r['value']!s:>14s} {r['unit'] or '-':>8s}{rng}{mark}\n"
              f"{'':50s} {r['text']}")
    return 0
