"""The flags every fanning-out verb shares: which cluster runs its jobs (``cluster.layer``)."""

from __future__ import annotations

import argparse
from typing import Any

from pam_bench.cli.errors import UsageError
from pam_bench.cli.numbers import integer

__all__ = ['add_cluster_args', 'cluster_of']


def add_cluster_args(p: Any) -> None:
    """--scheduler, --workers and the TLS files."""
    p.add_argument('--scheduler', metavar='ADDRESS', help='run the jobs on this Dask '
                   'scheduler (tcp://HOST:8786 or tls://...; default: $PAM_BENCH_SCHEDULER, '
                   'else a local cluster on 127.0.0.1)')
    p.add_argument('--workers', type=integer(1, 1024),
                   help='local cluster: worker processes (default: '
                   'one per core)')
    p.add_argument('--tls-cert', metavar='FILE', help="tls:// scheduler: this client's "
                   'certificate')
    p.add_argument('--tls-key', metavar='FILE', help='tls:// scheduler: its key')
    p.add_argument('--tls-ca', metavar='FILE', help='tls:// scheduler: the CA that signed the '
                   "cluster's certificates")


def cluster_of(args: argparse.Namespace) -> dict[str, Any]:
    """``connect``'s keywords from the flags.

    Raises:
        UsageError: some TLS files named but not all three, or a worker count below 1.
    """
    from pam_bench.cluster.layer import TlsFiles
    files = (args.tls_cert, args.tls_key, args.tls_ca)
    if any(files) and not all(files):
        raise UsageError('TLS needs --tls-cert, --tls-key and --tls-ca together')
    if args.workers is not None and args.workers < 1:
        raise UsageError(f'--workers {args.workers}: at least 1')
    tls = TlsFiles(*files) if all(files) else None
    return {'scheduler': args.scheduler, 'workers': args.workers, 'tls': tls}
