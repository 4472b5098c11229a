"""A run's ROS domain, leased, so that two runs on one machine never exchange a message.

Many labs export one ``ROS_DOMAIN_ID`` in every shell; two runs started from two shells then
share a domain, and DDS would hand each one the other's clock ticks, acknowledgements and
readings. Every run therefore holds a lease on what it uses of its domain, an ``flock`` on a
file in ``LEASE_DIR`` (machine-wide, whatever ``TMPDIR`` a run has; the kernel drops the lock
when the process dies, however it dies):

* a lock-step run is self-contained (it starts every node it talks to), so it takes its domain
  whole (``private_domain``): the domain it was given if no other run uses it, else the next
  safe domain nobody holds, and it says which;
* a wall-clock run meets nodes it did not start (a lab's drivers, ``emulate``, its own
  controllers by hand), so it shares the domain it was given (``shared_domain``) and leases
  only the node names it starts in its namespace: a second run that would start a node of the
  same name in the same namespace and domain is refused before anything starts, naming the
  run that holds it. A lock-step run never takes a domain a wall-clock run is in, and the
  reverse.

Lease files are removed by the last holder; a file whose holder died is taken over.
"""

from __future__ import annotations

import contextlib
import dataclasses
import errno
import fcntl
import os
import pathlib
import sys
from collections.abc import Iterator, Sequence

from pam_bench.bringup.errors import DomainInUseError
from pam_bench.cluster.layer import SAFE_DOMAINS

__all__ = ['LEASE_DIR_ENV', 'lease_dir', 'private_domain', 'shared_domain', 'who_holds',
           'wanted_domain']

LEASE_DIR_ENV = 'PAM_BENCH_LEASE_DIR'
"""Moves the lease folder (tests); every run on one machine must see the same one."""


def lease_dir() -> pathlib.Path:
    """The folder of the lease files: ``$PAM_BENCH_LEASE_DIR``, else /tmp/pam_bench_leases
    (not under ``TMPDIR``: runs with different ``TMPDIR`` must see each other's leases)."""
    path = pathlib.Path(os.environ.get(LEASE_DIR_ENV) or '/tmp/pam_bench_leases')
    path.mkdir(parents=True, exist_ok=True)
    with contextlib.suppress(OSError):       # other users of the machine lease here too
        if path.stat().st_uid == os.getuid():
            path.chmod(0o1777)
    return path


def wanted_domain(domain_id: int | None = None) -> int:
    """The domain a run asks for: ``domain_id``, else ``ROS_DOMAIN_ID``, else one derived from
    the process id."""
    if domain_id is not None:
        return domain_id
    text = os.environ.get('ROS_DOMAIN_ID', '').strip()
    return int(text) if text else 1 + os.getpid() % 100


def _holder_text() -> str:
    """Who holds a lease, for the message of the run that cannot have it."""
    prog = pathlib.Path(sys.argv[0]).name if sys.argv and sys.argv[0] else 'python'
    args = ' '.join(a if len(a) < 60 else a[:57] + '...' for a in sys.argv[1:8])
    return f'pid {os.getpid()}: {prog} {args}'.strip()


@dataclasses.dataclass
class _Lock:
    """One held lease file."""

    path: pathlib.Path
    fd: int
    exclusive: bool

    def release(self) -> None:
        """Drop the lock; the last holder removes the file."""
        try:
            if not self.exclusive:
                try:
                    fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError:
                    return                    # another run still shares it
            with contextlib.suppress(FileNotFoundError):
                if os.fstat(self.fd).st_ino == os.stat(self.path).st_ino:
                    os.unlink(self.path)
        finally:
            os.close(self.fd)


def _lock(path: pathlib.Path, exclusive: bool) -> _Lock | None:
    """Take the lease file ``path`` without waiting (None: another run holds it)."""
    for _ in range(20):
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, (fcntl.LOCK_EX if exclusive else fcntl.LOCK_SH) | fcntl.LOCK_NB)
        except OSError as exc:
            os.close(fd)
            if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                return None
            raise
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:                          # not a file its last holder removed meanwhile
            if exclusive:
                os.ftruncate(fd, 0)
                os.write(fd, _holder_text().encode())
            return _Lock(path, fd, exclusive)
        os.close(fd)
    return None


def who_holds(path: pathlib.Path) -> str:
    """What the holder of a lease file wrote into it ('' when nothing)."""
    try:
        return path.read_text(encoding='utf-8', errors='replace').strip()[:200]
    except OSError:
        return ''


def _domain_file(domain: int) -> pathlib.Path:
    return lease_dir() / f'domain_{domain}'


@contextlib.contextmanager
def private_domain(wanted: int, quiet: bool = False) -> Iterator[int]:
    """A domain for a lock-step run alone: ``wanted`` when no other run holds it, else the
    next safe domain nobody holds (a line on stderr says so unless ``quiet``).

    Raises:
        DomainInUseError: every safe domain is held.
    """
    start = SAFE_DOMAINS.index(wanted) if wanted in SAFE_DOMAINS else 0
    order = [wanted] + [d for d in SAFE_DOMAINS[start:] + SAFE_DOMAINS[:start] if d != wanted]
    for domain in order:
        lock = _lock(_domain_file(domain), exclusive=True)
        if lock is None:
            continue
        if domain != wanted and not quiet:
            held = who_holds(_domain_file(wanted)) or 'a wall-clock bench'
            sys.stderr.write(f'note: ROS_DOMAIN_ID {wanted} is in use by another pam_bench '
                             f'run ({held}); this lock-step run uses domain {domain}\n')
        try:
            yield domain
        finally:
            lock.release()
        return
    raise DomainInUseError(f'every ROS domain is held by another pam_bench run (lease files in '
                           f'{lease_dir()})')


@contextlib.contextmanager
def shared_domain(domain: int, namespace: str, nodes: Sequence[str]) -> Iterator[int]:
    """``domain`` shared with other wall-clock benches, the names of ``nodes`` in
    ``namespace`` leased to this run alone.

    Raises:
        DomainInUseError: a lock-step run holds the domain, or another run the name of one of
            ``nodes`` in ``namespace`` (the message names it and what to change).
    """
    held: list[_Lock] = []
    try:
        dom = _lock(_domain_file(domain), exclusive=False)
        if dom is None:
            raise DomainInUseError(
                f'ROS_DOMAIN_ID {domain} is in use by a lock-step run '
                f'({who_holds(_domain_file(domain)) or "another pam_bench run"}): wait for it '
                'to end or export another ROS_DOMAIN_ID')
        held.append(dom)
        ns = namespace.strip('/').replace('/', '.') or '_root'
        for name in nodes:
            path = lease_dir() / f'node_{domain}_{ns}_{name}'
            lock = _lock(path, exclusive=True)
            if lock is None:
                where = f'namespace /{namespace.strip("/")}' if namespace.strip('/') else \
                    'the root namespace'
                raise DomainInUseError(
                    f'node {name} already runs in ROS_DOMAIN_ID {domain}, {where} '
                    f'({who_holds(path) or "another pam_bench run"}): give --namespace, '
                    'export another ROS_DOMAIN_ID, or leave that device to it with '
                    f'--external {name}')
            held.append(lock)
        yield domain
    finally:
        for lock in reversed(held):
            lock.release()
