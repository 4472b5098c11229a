"""``pam-bench``: the parser, built from one module per group of verbs, and the entry point."""

from __future__ import annotations

import argparse
import os
import signal
import sys
from typing import NoReturn

from pam_bench.cli import bags, bench, design, fit, plugins, run
from pam_bench.cli.errors import Terminated, exit_code

__all__ = ['main', 'parser', 'GROUPS']

GROUPS = (run, bags, fit, design, bench, plugins)
"""The verb groups, each registering its own parsers (``register``)."""


_received: list[int] = []
"""The stop signals this process got (a verb that caught the interrupt still exits 143 on
SIGTERM)."""


def _raise_interrupt(signum: int, frame: object) -> None:
    _received.append(signum)
    raise Terminated


class _Parser(argparse.ArgumentParser):
    """An argument parser whose mistakes are one line (the usage is one ``-h`` away)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f'{self.prog}: error: {message} (see {self.prog} -h)\n')


def parser() -> argparse.ArgumentParser:
    """The whole command line."""
    ap = _Parser(prog='pam-bench', description='pam_bench: a pneumatic-muscle '
                                 'test bench as ROS 2 nodes, and its offline analysis.')
    sub = ap.add_subparsers(dest='cmd', required=True)
    for group in GROUPS:
        group.register(sub)
    return ap


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pam-bench``: parse, run the verb, map its errors (``cli.errors``)."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    # small matrices only: BLAS thread pools just spin against the node processes
    for var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
        os.environ.setdefault(var, '1')
    # Ctrl-C and SIGTERM end a run: nodes stopped, bag closed, no orphans. Installed whatever
    # was inherited: a background job of a non-interactive shell starts with SIGINT ignored.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _raise_interrupt)
    args = parser().parse_args(argv)
    try:
        code = int(args.func(args))
    except (KeyboardInterrupt, BrokenPipeError, Exception) as exc:  # noqa: BLE001 - mapped
        code = exit_code(exc)
    return 143 if code == 130 and signal.SIGTERM in _received else code


if __name__ == '__main__':
    sys.exit(main())
