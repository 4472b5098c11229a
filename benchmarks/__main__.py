"""``python -m benchmarks`` (``make bench``): run the studies -> BENCHMARKS.md and bench.json."""

from __future__ import annotations

import argparse
import pathlib
import sys

from benchmarks.errors import UsageError
from benchmarks.studies import STUDIES
from benchmarks.suite import render_report, run_benchmarks
from benchmarks.tables import REPOSITORY, RESULTS

__all__ = ['main']


def parser() -> argparse.ArgumentParser:
    """The options of ``python -m benchmarks``."""
    p = argparse.ArgumentParser(prog='python -m benchmarks',
                                description='benchmarks -> BENCHMARKS.md and bench.json')
    p.add_argument('--quick', action='store_true', help='a few minutes: quick grids and scenes')
    p.add_argument('--root', default=str(REPOSITORY),
                   help='where to write the report (default: this clone)')
    p.add_argument('--scene', action='append', help='scene to time (repeatable)')
    p.add_argument('--only', action='append', metavar='STUDY[,STUDY]',
                   help='run only these studies (--list names them) and keep the other figures '
                   'of bench.json, each with the commit it was measured at')
    p.add_argument('--list', action='store_true', help='list the studies and what each '
                   'measures')
    p.add_argument('--render', action='store_true', help='only render BENCHMARKS.md again from '
                   'bench.json and docs/long_runs.md (no measurement)')
    return p


def main(argv: list[str] | None = None) -> int:
    """Run ``python -m benchmarks``; returns the exit code (2: a usage error, one line)."""
    args = parser().parse_args(argv)
    root = pathlib.Path(args.root)
    if args.list:
        for study in STUDIES:
            print(f'{study.key:16s} {study.text}')
        return 0
    try:
        if args.render:
            print(f'wrote {render_report(root)} from {root / RESULTS / "bench.json"}')
            return 0
        only = [s for part in args.only or [] for s in part.split(',') if s]
        run_benchmarks(args.quick, root, args.scene or None, only or None)
    except (UsageError, FileNotFoundError) as exc:
        print(f'python -m benchmarks: error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print('python -m benchmarks: interrupted', file=sys.stderr)
        return 130
    print(f'wrote {root / "BENCHMARKS.md"} and {root / RESULTS / "bench.json"}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
