"""A Dask cluster of separate processes on 127.0.0.1: ``dask scheduler`` and ``dask worker``
of this venv, as a lab starts them on its machines (README, "Running on a cluster"), started
here for the real-cluster tests and the scaling study and stopped whatever happens.

Every process gets its own process group (a signal to the test or the study does not reach
it) and its own log file in ``log_dir``; stopping sends SIGTERM to each group (the workers',
then the scheduler's), then SIGKILL to any still alive after ``STOP_TIMEOUT_S``.
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator, Sequence
from typing import Any

__all__ = ['free_port', 'loopback_cluster', 'stop_processes', 'STOP_TIMEOUT_S']

STOP_TIMEOUT_S = 15.0
DASK = pathlib.Path(sys.executable).with_name('dask')


def free_port() -> int:
    """A TCP port free on 127.0.0.1 now."""
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return int(s.getsockname()[1])


def _start(args: list[str], log: pathlib.Path) -> subprocess.Popen:
    with open(log, 'w', encoding='utf-8') as fh:
        return subprocess.Popen([str(DASK), *args], stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True,
                                env=dict(os.environ, PYTHONWARNINGS='ignore'))


def stop_processes(procs: Sequence[subprocess.Popen], timeout_s: float = STOP_TIMEOUT_S
                   ) -> None:
    """SIGTERM to each process group, SIGKILL to those still alive after ``timeout_s``."""
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


@contextlib.contextmanager
def loopback_cluster(log_dir: pathlib.Path, workers: int = 2, nanny: bool = True,
                     tls: Sequence[str] = (), security: Any = None, wait_s: float = 60.0
                     ) -> Iterator[tuple[str, list[subprocess.Popen]]]:
    """A scheduler and ``workers`` single-threaded workers (``w0``, ``w1``, ...) on 127.0.0.1,
    up and registered, for the ``with`` block.

    Args:
        log_dir: where ``scheduler.log`` and ``worker<i>.log`` go.
        workers: how many workers.
        nanny: run each worker under a nanny (False: killing the process kills the worker).
        tls: the ``--tls-*`` options of scheduler and workers; the cluster then speaks TLS.
        security: the client ``Security`` that waits for the workers (with ``tls``).
        wait_s: how long the workers may take to register (s).

    Yields:
        (the scheduler's address, [the scheduler's process, the workers' processes]).
    """
    from distributed import Client
    port = free_port()
    address = f'{"tls" if tls else "tcp"}://127.0.0.1:{port}'
    procs = [_start(['scheduler', '--host', '127.0.0.1', '--port', str(port), '--no-dashboard',
                     *(['--protocol', 'tls'] if tls else []), *tls],
                    log_dir / 'scheduler.log')]
    try:
        for i in range(workers):
            procs.append(_start(['worker', address, '--host', '127.0.0.1', '--nthreads', '1',
                                 '--no-dashboard', '--name', f'w{i}',
                                 *([] if nanny else ['--no-nanny']), *tls],
                                log_dir / f'worker{i}.log'))
        with Client(address, security=security, timeout='30s') as c:
            c.wait_for_workers(workers, timeout=wait_s)
        yield address, procs
    finally:
        # the workers first: a worker told to stop while its scheduler closes can hang in its
        # own close until SIGKILL (``STOP_TIMEOUT_S`` lost per test and study here)
        stop_processes(procs[1:])
        stop_processes(procs[:1])
