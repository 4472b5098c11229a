"""``pam-bench``: the parser, built from one module per group of verbs, and the entry point."""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from typing import NoReturn

from pam_bench.cli.errors import Terminated, check_limits, exit_code

__all__ = ['main', 'parser', 'GROUP_MODULES']

GROUP_MODULES = ('run', 'bags', 'fit', 'design', 'bench', 'plugins')
"""The verb groups (modules of ``pam_bench.cli``), each registering its own parsers
(``register``). Imported when the parser is built, after ``main`` has put its signal handlers
in place: a Ctrl-C while they import (numpy among them, a tenth of a second) is an interrupt
like any other, not a traceback."""


_received: list[int] = []
"""The stop signals this process got (a verb that caught the interrupt still exits 143 on
SIGTERM)."""


STOP_GRACE_S = 60.0
"""How long a verb may take to stop after Ctrl-C or SIGTERM (nodes stopped, bag closed)
before the process exits anyway; a second signal exits at once."""


def _raise_interrupt(signum: int, frame: object) -> None:
    _received.append(signum)
    raise Terminated


def _raise_keyboard(signum: int, frame: object) -> None:
    _received.append(signum)
    raise KeyboardInterrupt


def _watch_stops() -> None:
    """A thread that sees every stop signal as the kernel delivers it (Python's wake-up
    fd), even while the main thread is stuck in a C call that never returns to Python (a
    library spinning on an allocation the memory limit refuses): one second signal, or
    ``STOP_GRACE_S`` after the first, ends the process with one line and the signal's exit
    code. What was recorded stays on disk (``bag-repair`` closes a bag cut off so)."""
    import select
    import threading
    import time
    if any(t.name == 'stop-watch' for t in threading.enumerate()):
        return                               # main() called again in one process
    read, write = os.pipe()
    os.set_blocking(write, False)
    try:
        signal.set_wakeup_fd(write, warn_on_full_buffer=False)
    except ValueError:                       # not the main thread (a test harness)
        os.close(read)
        os.close(write)
        return

    def watch() -> None:
        first: float | None = None
        seen: list[int] = []
        while True:
            wait = None if first is None else max(0.0, first + STOP_GRACE_S - time.monotonic())
            ready, _, _ = select.select([read], [], [], wait)
            if ready:
                seen += [s for s in os.read(read, 64) if s in (signal.SIGINT, signal.SIGTERM)]
            if not seen:
                continue
            if first is None and len(seen) == 1:
                first = time.monotonic()
                continue
            why = 'a second stop signal' if len(seen) > 1 else \
                f'no stop within {STOP_GRACE_S:g} s of the signal'
            os.write(2, f'error: {why}: exited at once (a bag cut off here: pam-bench '
                     'bag-repair)\n'.encode())
            os._exit(143 if signal.SIGTERM in seen else 130)
    threading.Thread(target=watch, name='stop-watch', daemon=True).start()


class _Parser(argparse.ArgumentParser):
    """An argument parser whose mistakes are one line (the usage is one ``-h`` away)."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f'{self.prog}: error: {message} (see {self.prog} -h)\n')


def parser() -> argparse.ArgumentParser:
    """The whole command line."""
    ap = _Parser(prog='pam-bench', description='pam_bench: a pneumatic-muscle '
                                 'test bench as ROS 2 nodes, and its offline analysis.')
    sub = ap.add_subparsers(dest='cmd', required=True)
    for name in GROUP_MODULES:
        importlib.import_module(f'pam_bench.cli.{name}').register(sub)
    return ap


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pam-bench``: parse, run the verb, map its errors (``cli.errors``)."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    # small matrices only: BLAS thread pools just spin against the node processes
    for var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
        os.environ.setdefault(var, '1')
    # Ctrl-C and SIGTERM end a run: nodes stopped, bag closed, no orphans. Installed whatever
    # was inherited: a background job of a non-interactive shell starts with SIGINT ignored.
    _received.clear()
    signal.signal(signal.SIGINT, _raise_keyboard)
    signal.signal(signal.SIGTERM, _raise_interrupt)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM})  # and the
    _watch_stops()                                          # mask a parent may have left
    try:
        args = parser().parse_args(argv)
        check_limits()
        code = int(args.func(args))
    except (KeyboardInterrupt, BrokenPipeError, Exception) as exc:  # noqa: BLE001 - mapped
        # after a stop signal, whatever it broke is the stop (numpy's import, cut by Ctrl-C,
        # raises an ImportError)
        code = exit_code(exc if not _received or isinstance(exc, (KeyboardInterrupt, Terminated))
                         else KeyboardInterrupt())
    if code == 130:
        # a cluster stopped while it started: Dask's exit hook then fails on its half-made
        # workers and prints a traceback after the one line (the processes still go)
        sys.unraisablehook = lambda _: None
    return 143 if code == 130 and signal.SIGTERM in _received else code


def command() -> NoReturn:
    """The ``pam-bench`` executable: ``main`` on the process's arguments, then the process
    ends as a node's does, Python's exit handlers run (``runtime.leaving.leave``: Fast DDS's
    destructors and the interpreter's teardown added 0.2 s to the demo's 1.2 s). ``main``
    itself returns, for callers in a process that goes on. The process is the command's own,
    so the bench's discovery profile goes into its environment (``config.dds``, unless it
    names one): its own participants (the recorder of ``record``, the probe of
    ``check-drivers``, the lifecycle manager of a wall-clock run) announce themselves every
    0.5 s too, which a lab's driver started without it answers at once."""
    import os

    from pam_bench.config.dds import discovery_profile_env
    from pam_bench.runtime.leaving import leave
    discovery_profile_env(os.environ)
    leave(main(), exit_handlers=True)


if __name__ == '__main__':
    command()
