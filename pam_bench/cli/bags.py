"""Verbs over recorded bags: info, diff, bag-repair."""

from __future__ import annotations

import argparse
import pathlib
from typing import Any

from pam_bench.cli.json_out import dumps

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('info', help='how a bag was made and what it holds')
    p.add_argument('bag')
    p.add_argument('--parameters', action='store_true', help="print every node's resolved "
                   'parameters too')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_info)
    p = sub.add_parser('diff', help='two bags compared reading by reading (exit 1: differ)')
    p.add_argument('bag_a')
    p.add_argument('bag_b')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_diff)
    p = sub.add_parser('bag-repair', help='rebuild a bag whose recorder was killed')
    p.add_argument('bag', help='rosbag2 folder')
    p.set_defaults(func=_cmd_bag_repair)


def _flatten(d: dict[str, Any], prefix: str = '') -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in d.items():
        out.update(_flatten(v, f'{prefix}{k}.') if isinstance(v, dict) else {prefix + k: v})
    return out


def _cmd_info(args: argparse.Namespace) -> int:
    from pam_bench.bags.baginfo import bag_info
    info = bag_info(args.bag)
    if args.json:
        print(dumps(info))
        return 0
    run, end = info['run'] or {}, info['end'] or {}
    if run:
        v = run.get('versions', {})
        print(f"scene     {run['scene']} (seed {run['seed']}, {run.get('layout', '?')})\n"
              f"commit    {run['commit']}" + (' (dirty)' if run.get('dirty') else '') + '\n'
              f"made      {run['start']} on {run['host']}\n"
              f"command   {' '.join(run.get('command_line', []))}\n"
              f"versions  pam_bench {v.get('pam_bench')}, rclpy {v.get('rclpy')}, rosbags "
              f"{v.get('rosbags')}, numpy {v.get('numpy')}\n"
              f"nodes     {', '.join(k for k in run.get('parameters', {}) if k != 'sim_clock')}")
        if args.parameters:
            for node, p in run.get('parameters', {}).items():
                flat = _flatten(p.get('ros__parameters', {}))
                shown = {k: v for k, v in flat.items() if k not in ('run_yaml', 'end_file')}
                print(f'  {node}: ' + ', '.join(f'{k}={v}' for k, v in sorted(shown.items())))
    else:
        print('no run description in this bag (a recorder started by hand, an older '
              'pam_bench or another recorder)')
    if end:
        print(f"ended     {end.get('state')}" + (f": {end['reason']}" if end.get('reason')
                                                 else '') + f" at {end.get('end')}")
    print(f"duration  {info['duration_s']:.3f} s of log time")
    size = sum(n for _, n in info['files'])
    print(f"files     {len(info['files'])}, {size / 1e6:.1f} MB, chunks "
          f"{info['compression'] or 'uncompressed'}" + (
              f" ({info['files'][0][0]} ... {info['files'][-1][0]})"
              if len(info['files']) > 1 else ''))
    for topic, t in sorted(info['topics'].items()):
        print(f"  {topic:34s} {t['count']:9d}  {t['type']}")
    return 0


def _cmd_diff(args: argparse.Namespace) -> int:
    from pam_bench.bags.bagdiff import diff_bags
    d = diff_bags(args.bag_a, args.bag_b)
    if args.json:
        print(dumps(d))
    same = True
    for name, row in d.items():
        worst = {k: v for k, v in row.items() if k.startswith('max_')}
        same &= row['only_a'] == row['only_b'] == 0 and all(v == 0 for v in worst.values())
        if not args.json:
            print(f"{name:24s} {row['matched']:6d} matched, {row['only_a']} only in A, "
                  f"{row['only_b']} only in B; largest: "
                  + ', '.join(f'{k[4:]} {v:.6g}' for k, v in worst.items()))
    print('identical readings' if same else 'the bags differ')
    return 0 if same else 1


def _cmd_bag_repair(args: argparse.Namespace) -> int:
    from pam_bench.bags.bag_repair import OLD_METADATA, repair_bag
    rep = repair_bag(args.bag)
    if not rep.needed:
        print(f'{args.bag} is a valid bag: every chunk decompresses and passes its CRC; '
              'nothing to repair')
        return 0
    what = 'damaged' if rep.bad_chunks else 'torn'
    print(f'{args.bag} was {what}: rebuilt {", ".join(rep.rebuilt)} from its readable records '
          f'({rep.bad_chunks} damaged chunk(s) dropped, {rep.lost_bytes} bytes unreadable); '
          f'the originals are kept in {rep.broken_copy}'
          + (f', the old metadata in {args.bag}/{OLD_METADATA}'
             if (pathlib.Path(args.bag) / OLD_METADATA).exists() else ''))
    for topic, n in sorted(rep.kept.items()):
        print(f'  {topic:34s} {n:8d} messages kept')
    return 0
