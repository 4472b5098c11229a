"""Verbs that measure: bench (BENCHMARKS.md), servo-compare, pingpong."""

from __future__ import annotations

import argparse
import json
import pathlib
from typing import Any

from pam_bench.cli.cluster_args import add_cluster_args, cluster_of
from pam_bench.cli.errors import UsageError
from pam_bench.cli.numbers import integer, number, out_path

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('pingpong', help='rclpy round-trip rate between two processes')
    p.add_argument('--count', type=integer(1, 10_000_000), default=2000)
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_pingpong)
    p = sub.add_parser('servo-compare', help='every servo scene x controller -> metrics.json')
    p.add_argument('--engine', choices=['twin', 'ros'], default='ros',
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
    p.add_argument('--duration', type=number(0, 86_400, 's', True),
                   help='sim time per run, s (default: the scene)')
    p.add_argument('--processes', action='store_true',
                   help='with --engine ros: every node in its own process (same bags, slower)')
    add_cluster_args(p)
    p.set_defaults(func=_cmd_servo_compare)
    p = sub.add_parser('bench', help='benchmarks -> BENCHMARKS.md and bench.json')
    p.add_argument('--quick', action='store_true', help='a few minutes: quick grids and scenes')
    p.add_argument('--root', default='.', help='where to write the report (default: here)')
    p.add_argument('--scene', action='append', help='scene to time (repeatable)')
    p.add_argument('--only', action='append', metavar='STUDY[,STUDY]',
                   help='run only these studies (--list names them) and keep the other figures '
                   'of bench.json, each with the commit it was measured at')
    p.add_argument('--list', action='store_true', help='list the studies and what each '
                   'measures')
    p.add_argument('--render', action='store_true', help='only render BENCHMARKS.md again from '
                   'bench.json and docs/long_runs.md (no measurement)')
    p.set_defaults(func=_cmd_bench)


def _cmd_pingpong(args: argparse.Namespace) -> int:
    from pam_bench.benchmarks.pingpong import pingpong_rate
    rate = pingpong_rate(args.count)
    print(json.dumps({'pingpong_round_trips_per_s': rate}) if args.json
          else f'rclpy ping-pong between two processes: {rate:.0f} round trips/s')
    return 0


def _cmd_servo_compare(args: argparse.Namespace) -> int:
    from pam_bench.benchmarks.servo_compare import compare_servo
    from pam_bench.config.settings import CONTROLLERS
    from pam_bench.vocabulary.outputs import staged_output
    from pam_bench.vocabulary.params import hint
    for name in args.controller or []:
        if name not in CONTROLLERS:
            near = hint(name, CONTROLLERS)
            raise UsageError(f'--controller {name!r}: not a controller here ({near}; '
                             'pam-bench plugins lists the installed ones)')
    out = pathlib.Path(args.out)
    cluster = cluster_of(args)
    with staged_output(out, 'pam-bench servo-compare', args.overwrite) as tmp:
        from pam_bench.vocabulary.run import Layout
        rows = compare_servo(tmp, args.engine, args.scene or None, args.duration,
                             Layout.PROCESSES if args.processes else Layout.COMPOSED, cluster,
                             args.controller)
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
    from pam_bench.benchmarks.suite import render_report, run_benchmarks
    root = pathlib.Path(args.root)
    if args.list:
        from pam_bench.benchmarks.studies import STUDIES
        for study in STUDIES:
            print(f'{study.key:16s} {study.text}')
        return 0
    if args.render:
        print(f'wrote {render_report(root)} from {root / "results" / "bench.json"}')
        return 0
    only = [s for part in args.only or [] for s in part.split(',') if s]
    run_benchmarks(args.quick, root, args.scene or None, only or None)
    print(f'wrote {root / "BENCHMARKS.md"} and {root / "results" / "bench.json"}')
    return 0
