"""Verbs that measure: servo-compare, pingpong, and bench (a clone's benchmark studies)."""

from __future__ import annotations

import argparse
import pathlib
from typing import Any

from pam_bench.cli.cluster_args import add_cluster_args, cluster_of
from pam_bench.cli.errors import UsageError
from pam_bench.cli.json_out import dumps
from pam_bench.cli.numbers import integer, number, out_path

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('pingpong', help='rclpy round-trip rate between two processes')
    p.add_argument('--count', type=integer(1, 10_000_000), default=2000)
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_pingpong)
    p = sub.add_parser('servo-compare', help='every servo scene x controller -> metrics.json')
    from pam_bench.vocabulary.run import ENGINES
    p.add_argument('--engine', choices=ENGINES, default='ros',
                   help='ros: the nodes, composed (--processes: one process each); twin: the '
                   'same models without ROS (seconds)')
    p.add_argument('--out', type=out_path,
                   default='reports/servo', help='output folder (new; it takes its '
                   'place once complete)')
    p.add_argument('--overwrite', action='store_true', help='replace --out, an earlier '
                   'servo-compare (only the files it wrote)')
    p.add_argument('--scene', action='append', help='servo scene (repeatable; default all)')
    p.add_argument('--controller', action='append', metavar='NAME', help='a controller '
                   'plug-in to rank beside the built-ins (repeatable; pam-bench plugins)')
    p.add_argument('--set', action='append', default=[], metavar='PATH=VALUE',
                   help='set one setting by its path over every scene, as run --set does, '
                   'e.g. torque_servo.plugins.NAME.FIELD=1.5 (repeatable)')
    p.add_argument('--duration', type=number(0, 86_400, 's', True),
                   help='sim time per run, s (default: the scene)')
    p.add_argument('--processes', action='store_true',
                   help='with --engine ros: every node in its own process (same bags, slower)')
    add_cluster_args(p)
    p.set_defaults(func=_cmd_servo_compare)
    p = sub.add_parser('bench', help="the benchmark studies: runs a clone's `python -m "
                       "benchmarks` with these options (--list, --only, --quick, --render)",
                       add_help=False)
    p.add_argument('options', nargs=argparse.REMAINDER)
    p.set_defaults(func=_cmd_bench)


def _cmd_pingpong(args: argparse.Namespace) -> int:
    from pam_bench.bringup.pingpong import pingpong_rate
    rate = pingpong_rate(args.count)
    print(dumps({'pingpong_round_trips_per_s': rate}, indent=None) if args.json
          else f'rclpy ping-pong between two processes: {rate:.0f} round trips/s')
    return 0


def _cmd_servo_compare(args: argparse.Namespace) -> int:
    from pam_bench.bringup.servo_compare import compare_servo
    from pam_bench.config.settings import CONTROLLERS
    from pam_bench.vocabulary.outputs import staged_output
    from pam_bench.vocabulary.params import hint
    for name in args.controller or []:
        if name not in CONTROLLERS:
            near = hint(name, CONTROLLERS)
            raise UsageError(f'--controller {name!r}: not a controller here ({near}; '
                             'pam-bench plugins lists the installed ones)')
    from pam_bench.bringup.servo_compare import servo_scenes
    from pam_bench.cli.run import load_with_sets, parse_value
    for name in args.scene or servo_scenes():      # every scene and --set checked first
        load_with_sets(name, args.set)
    sets = tuple((p.strip(), parse_value(v)) for p, _, v in
                 (item.partition('=') for item in args.set))
    out = pathlib.Path(args.out)
    cluster = cluster_of(args)
    with staged_output(out, 'pam-bench servo-compare', args.overwrite) as tmp:
        from pam_bench.vocabulary.run import Layout
        rows = compare_servo(tmp, args.engine, args.scene or None, args.duration,
                             Layout.PROCESSES if args.processes else Layout.COMPOSED, cluster,
                             args.controller, sets)
    rows = sorted(rows, key=lambda r: (r['scene'], r['rms_error']))   # ranked per scene
    print(f"{'scene':26s} {'controller':20s} {'RMS':>8s} {'max':>8s} {'at reversal':>12s}")
    for r in rows:
        print(f"{r['scene']:26s} {r['controller']:20s} {r['rms_error']:8.3f} "
              f"{r['max_error']:8.3f} {r['error_at_reversal']:12.3f} {r['unit']}")
    forward = [r for r in rows if 'forward_model_rms_N' in r]
    if forward:
        print("004's forward model (Eq. 4) driven by each run's voltage, RMS against the "
              'measured force:')
        for r in forward:
            print(f"  {r['scene']:24s} {r['controller']:20s} {r['forward_model_rms_N']:8.2f} N")
    print(f'wrote {out / "metrics.json"} and one plot per scene')
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    """The studies are not in the installed package (``benchmarks/`` at a clone's top): run
    them in the clone around the working folder."""
    import subprocess
    import sys
    here = pathlib.Path.cwd().resolve()
    for root in (here, *here.parents):
        if (root / 'benchmarks' / 'studies.py').is_file():
            return subprocess.run([sys.executable, '-m', 'benchmarks', *args.options],
                                  cwd=root, check=False).returncode
    raise UsageError('bench: the benchmark studies live in a clone of pam_bench (benchmarks/); '
                     'run `make bench` there')
