"""The verb that lists what a lab has added: ``pam-bench plugins``."""

from __future__ import annotations

import argparse
from typing import Any

from pam_bench.cli.json_out import dumps

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('plugins', help='the plug-ins installed beside pam_bench: force laws '
                       'and controllers (entry points), one line each')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_plugins)


def _cmd_plugins(args: argparse.Namespace) -> int:
    from pam_bench.control.plugins import GROUP as CONTROLLERS
    from pam_bench.control.plugins import unusable as controller_problem
    from pam_bench.models.laws.base import law_function
    from pam_bench.models.laws.zoo import GROUP as LAWS
    from pam_bench.models.laws.zoo import unusable as law_problem
    from pam_bench.vocabulary.plugins import discover
    rows = []
    for group, kind, check in ((LAWS, 'muscle law', law_problem),
                               (CONTROLLERS, 'controller', controller_problem)):
        for p in discover(group):
            why = check(p)
            status = f'not usable: {why}' if why else 'ok'
            if not why and group == LAWS:           # compiled like the built-ins, or not
                slow = law_function(p.obj)[1]
                status = f'ok, runs interpreted: {slow}' if slow else 'ok, compiled'
            rows.append({'kind': kind, 'name': p.name, 'package': p.package,
                         'status': status})
    if args.json:
        print(dumps(rows))
    elif not rows:
        print('no plug-ins installed (entry-point groups pam_bench.muscle_laws, '
              'pam_bench.controllers; examples/pam_bench_example is one)')
    for r in [] if args.json else rows:
        print(f"{r['kind']:11s} {r['name']:24s} {r['package']:24s} {r['status']}")
    return 0
