"""The execution layer: every fan-out of the bench (batch extraction and calibration, sweeps,
servo comparisons, a calibration's Jacobian, the benchmark studies) runs its jobs on Dask.

By default ``connect`` starts an in-process ``LocalCluster``: one worker process per core, one
thread each, its scheduler and workers on 127.0.0.1 (no dashboard). ``scheduler`` (or
``PAM_BENCH_SCHEDULER``) names a running cluster instead (``dask scheduler`` and ``dask worker
ADDRESS`` on each machine); a ``tls://`` address needs the certificate, key and CA
(``TlsFiles``, or Dask's own configuration).

``run_jobs`` runs one function over many items and returns one ``JobResult`` per item, in the
items' order: a job that raises is reported with its one-line error and the others complete; a
worker that dies has its jobs run again elsewhere by the scheduler. Progress shows as one
line: done/total, failed, ETA. A job that starts ROS nodes (``ros=True``) runs on a ROS domain
of its own worker (``worker_domain``) with DDS on loopback; other jobs need neither.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import sys
import time
import zlib
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from pam_bench.cluster.errors import ClusterError

__all__ = ['TlsFiles', 'JobResult', 'connect', 'run_jobs', 'worker_domain', 'SAFE_DOMAINS',
           'map_on']

SAFE_DOMAINS = [*range(1, 102), *range(215, 233)]
"""ROS_DOMAIN_IDs safe on Linux (ROS 2 docs)."""


@dataclasses.dataclass(frozen=True)
class TlsFiles:
    """Dask TLS: this client's certificate and key and the CA that signed the cluster's."""

    cert: str
    key: str
    ca: str


@dataclasses.dataclass
class JobResult:
    """One job: its item, whether it completed, its value or its one-line error, its wall
    time (s) and the worker that ran it."""

    item: Any
    ok: bool
    value: Any = None
    error: str = ''
    seconds: float = 0.0
    worker: str = ''


def _security(tls: TlsFiles | None) -> Any:
    if tls is None:
        return None
    from distributed.security import Security
    return Security(tls_ca_file=tls.ca, tls_client_cert=tls.cert, tls_client_key=tls.key,
                    require_encryption=True)


@contextlib.contextmanager
def connect(scheduler: str | None = None, workers: int | None = None,
            tls: TlsFiles | None = None) -> Iterator[Any]:
    """A Dask client: on ``scheduler`` (else ``PAM_BENCH_SCHEDULER``), else on a local cluster
    of ``workers`` processes (default: one per core) bound to 127.0.0.1.

    Raises:
        ClusterError: the scheduler cannot be reached (one line).
    """
    import logging

    from distributed import Client, LocalCluster
    # a Ctrl-C while futures are gathered leaves the client's tasks unretrieved: asyncio
    # would print one traceback for each after the verb's one line
    logging.getLogger('asyncio').setLevel(logging.CRITICAL)
    address = scheduler or os.environ.get('PAM_BENCH_SCHEDULER') or None
    if address:
        try:
            client = Client(address, security=_security(tls), timeout='15s')
        except (OSError, TimeoutError) as exc:
            raise ClusterError(f'cannot reach the scheduler at {address}: {exc}') from None
        except (ValueError, TypeError) as exc:       # distributed's parse of the address
            raise ClusterError(f'scheduler address {address!r}: {exc} (write '
                               'tcp://HOST:PORT or tls://HOST:PORT)') from None
        try:
            yield client
        finally:
            client.close()
        return
    import tempfile
    n = workers or os.cpu_count() or 1
    # the workers' scratch space in a folder of this run, removed with it (Dask's default,
    # $TMPDIR/dask-scratch-space, stays behind)
    import dask
    with tempfile.TemporaryDirectory(prefix='pam_bench_dask_') as scratch, \
            dask.config.set({'temporary-directory': scratch}), \
            LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host='127.0.0.1',
                         dashboard_address='127.0.0.1:0', silence_logs=logging.CRITICAL,
                         worker_dashboard_address='127.0.0.1:0',
                         local_directory=scratch) as cluster, \
            Client(cluster) as client:
        yield client


def worker_domain() -> int:
    """The ROS domain of the Dask worker this runs in, one per worker: the worker's slot (a
    local cluster's workers are named 0 .. n-1; another's name or address is hashed) picks
    ``PAM_BENCH_DOMAINS`` (a comma list) when set, else the slot-th safe domain after the
    ``ROS_DOMAIN_ID`` the worker inherited (its client's). Outside a worker: ROS_DOMAIN_ID."""
    own = int(os.environ.get('ROS_DOMAIN_ID', '') or 0)
    try:
        from distributed import get_worker
        w = get_worker()
    except (ImportError, ValueError):
        return own
    name = w.name
    slot = name if isinstance(name, int) else zlib.crc32(str(name or w.address).encode())
    listed = [int(d) for d in os.environ.get('PAM_BENCH_DOMAINS', '').split(',') if d.strip()]
    if listed:
        return listed[slot % len(listed)]
    start = SAFE_DOMAINS.index(own) + 1 if own in SAFE_DOMAINS else 0
    return SAFE_DOMAINS[(start + slot) % len(SAFE_DOMAINS)]


def _job(fn: Callable[[Any], Any], item: Any, ros: bool) -> tuple[bool, Any, str, float, str]:
    """Run one job in a worker; never lets an exception out (the batch goes on)."""
    t0 = time.perf_counter()
    where = ''
    try:
        from distributed import get_worker
        where = str(get_worker().address)
    except (ImportError, ValueError):
        pass
    if ros:
        os.environ['ROS_DOMAIN_ID'] = str(worker_domain())
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    try:
        value = fn(item)
    except Exception as exc:  # noqa: BLE001 - reported per job, the others complete
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else ''
        return False, None, f'{type(exc).__name__}: {text}', time.perf_counter() - t0, where
    return True, value, '', time.perf_counter() - t0, where


class _Progress:
    """One line: label, done/total, failed, ETA (rewritten in place on a terminal)."""

    def __init__(self, label: str, total: int, quiet: bool) -> None:
        self.label, self.total, self.quiet = label, total, quiet
        self.t0 = time.monotonic()
        self.done = self.failed = 0
        self.tty = sys.stderr.isatty()
        self._last = 0.0

    def update(self, ok: bool) -> None:
        self.done += 1
        self.failed += not ok
        now = time.monotonic()
        if self.quiet or (not self.tty and now - self._last < 2.0 and self.done < self.total):
            return
        self._last = now
        rate = self.done / max(now - self.t0, 1e-9)
        eta = (self.total - self.done) / rate if rate > 0 else float('inf')
        line = (f'{self.label}: {self.done}/{self.total} done'
                + (f', {self.failed} failed' if self.failed else '')
                + (f', ETA {eta:.0f} s' if self.done < self.total else
                   f' in {now - self.t0:.1f} s'))
        end = '\n' if self.done == self.total or not self.tty else ''
        print(('\r' if self.tty else '') + line, end=end, file=sys.stderr, flush=True)


def run_jobs(fn: Callable[[Any], Any], items: Sequence[Any], client: Any = None,
             label: str = 'jobs', ros: bool = False, quiet: bool = False,
             scheduler: str | None = None, workers: int | None = None,
             tls: TlsFiles | None = None,
             on_result: Callable[[JobResult], None] | None = None) -> list[JobResult]:
    """``fn(item)`` for every item on the cluster (``client``, else ``connect``'s), results
    in the items' order (module docstring); ``on_result`` is called with each result as its
    job ends (a sweep keeps what it finished, however it is stopped). ``fn`` must be
    importable by the workers (a module-level function) and its items and values
    picklable."""
    if not items:
        return []
    if client is None:
        with connect(scheduler, workers, tls) as c:
            return run_jobs(fn, items, c, label, ros, quiet, on_result=on_result)
    from distributed import as_completed
    progress = _Progress(label, len(items), quiet)
    futures = [client.submit(_job, fn, item, ros, pure=False) for item in items]
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[JobResult | None] = [None] * len(items)
    for fut in as_completed(futures):
        i = index[fut.key]
        try:
            ok, value, error, seconds, where = fut.result()
        except Exception as exc:  # noqa: BLE001 - a job the cluster itself lost
            ok, value, error, seconds, where = False, None, f'{type(exc).__name__}: {exc}', \
                0.0, ''
        result = out[i] = JobResult(items[i], ok, value, error, seconds, where)
        if on_result is not None:
            on_result(result)
        progress.update(ok)
    return [r for r in out if r is not None]


def map_on(client: Any) -> Callable[[Callable[[Any], Any], Any], list[Any]]:
    """A map-like callable on the cluster for scipy's ``workers=`` (a finite-difference
    Jacobian's columns); a failed evaluation raises (scipy has no use for a missing column)."""
    def mapper(fn: Callable[[Any], Any], iterable: Any) -> list[Any]:
        items = list(iterable)
        futures = client.map(fn, items, pure=False)
        return list(client.gather(futures))
    return mapper
