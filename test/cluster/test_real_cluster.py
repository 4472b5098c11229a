"""A real Dask cluster: ``dask scheduler`` and two ``dask worker`` processes of this venv on
127.0.0.1, started here and stopped in ``finally``. A small sweep and a batch extraction
through ``--scheduler`` equal the local run's; a worker killed with SIGKILL mid-sweep loses no
row and adds none; with TLS, a client without a certificate is refused."""

from __future__ import annotations

import csv
import os
import pathlib
import signal
import socket
import subprocess
import time
from collections.abc import Iterator

import pytest

from pam_bench.cluster.loopback import loopback_cluster
from pam_bench.sweep.results import RESULTS, run_sweep
from pam_bench.sweep.spec import load_sweep
from test.analysis.test_extract import isometric_points

SWEEP = """scene: isometric_quick
engine: twin
seeds: [1, 2]
grid:
  muscle_1.muscle.gain_exponent: [1.3, 1.4]
figures: [isometric.gain_N_per_V.max, isometric.gain_N_per_V.min]
"""


@pytest.fixture
def cluster(tmp_path: pathlib.Path) -> Iterator[tuple[str, list[subprocess.Popen]]]:
    with loopback_cluster(tmp_path, workers=2, nanny=False, wait_s=40) as running:
        yield running


def _rows(path: pathlib.Path) -> list[dict[str, str]]:
    with open(path, newline='') as fh:
        return [{k: v for k, v in r.items() if k != 'seconds'} for r in csv.DictReader(fh)]


def test_sweep_and_batch_extraction_on_an_external_scheduler_equal_the_local_run(
        tmp_path: pathlib.Path, cluster: tuple[str, list]) -> None:
    from pam_bench.analysis.batch import extract_each
    from pam_bench.bags.bagwrite import write_bag
    address, _ = cluster
    spec = tmp_path / 'sweep.yaml'
    spec.write_text(SWEEP)
    sweep = load_sweep(spec)
    run_sweep(sweep, tmp_path / 'far', {'scheduler': address})
    run_sweep(sweep, tmp_path / 'near', {'workers': 2})
    assert _rows(tmp_path / 'far' / RESULTS) == _rows(tmp_path / 'near' / RESULTS)
    assert all(r['status'] == 'ok' for r in _rows(tmp_path / 'far' / RESULTS))
    bags = []
    for name, g in (('a', 284.0), ('b', 270.0)):      # one series each: no law zoo to fit
        write_bag(tmp_path / name, isometric_points({0.0: g}))  # (10 s a bag; the transport
        bags.append(str(tmp_path / name))                     # is what this test is about)
    far = extract_each(bags, str(tmp_path / 'x_far'), {'scheduler': address})
    near = extract_each(bags, str(tmp_path / 'x_near'), {'workers': 1})
    strip = [{k: v for k, v in r.items() if k != 'date'} for r in far]
    assert strip == [{k: v for k, v in r.items() if k != 'date'} for r in near]
    assert [r['isometric.gain_N_per_V.max'] for r in far] == pytest.approx([284.0, 270.0],
                                                                            rel=0.02)


def test_a_worker_killed_mid_sweep_loses_no_row(tmp_path: pathlib.Path,
                                                cluster: tuple[str, list]) -> None:
    """The scheduler runs the dead worker's jobs on the other one: every row once, and the
    same figures as a local run."""
    import threading
    address, procs = cluster
    spec = tmp_path / 'sweep.yaml'
    spec.write_text(SWEEP.replace('seeds: [1, 2]', 'seeds: [1, 2, 3, 4, 5, 6]'))
    sweep = load_sweep(spec)

    def kill_when_busy() -> None:
        """SIGKILL worker w1 while it runs a job of the sweep."""
        from distributed import Client
        with Client(address, timeout='30s') as c:
            end = time.monotonic() + 40
            while time.monotonic() < end:
                info = c.scheduler_info()['workers']
                w1 = [a for a, w in info.items() if w['name'] == 'w1']
                busy = c.processing(workers=w1) if w1 else {}
                if any(busy.values()):
                    os.killpg(procs[1].pid, signal.SIGKILL)
                    return
                time.sleep(0.05)

    killer = threading.Thread(target=kill_when_busy)
    killer.start()
    rows = run_sweep(sweep, tmp_path / 'far', {'scheduler': address})
    killer.join()
    assert procs[1].poll() is not None                         # it did die mid-sweep
    assert len(rows) == len(sweep.jobs()) == len({r['job'] for r in rows})
    run_sweep(sweep, tmp_path / 'near', {'workers': 2})
    assert _rows(tmp_path / 'far' / RESULTS) == _rows(tmp_path / 'near' / RESULTS)


def _openssl(*args: str, cwd: pathlib.Path) -> None:
    subprocess.run(['openssl', *args], cwd=cwd, check=True, capture_output=True)


def _certificates(d: pathlib.Path) -> dict[str, str]:
    """A throwaway CA and one certificate for 127.0.0.1 signed by it."""
    _openssl('req', '-x509', '-newkey', 'rsa:2048', '-nodes', '-days', '1', '-subj',
             '/CN=pam_bench test CA', '-keyout', 'ca.key', '-out', 'ca.pem', cwd=d)
    (d / 'ext.cnf').write_text('subjectAltName=IP:127.0.0.1,DNS:localhost\n')
    _openssl('req', '-newkey', 'rsa:2048', '-nodes', '-subj', '/CN=127.0.0.1', '-keyout',
             'node.key', '-out', 'node.csr', cwd=d)
    _openssl('x509', '-req', '-in', 'node.csr', '-CA', 'ca.pem', '-CAkey', 'ca.key',
             '-CAcreateserial', '-days', '1', '-extfile', 'ext.cnf', '-out', 'node.pem', cwd=d)
    return {'ca': str(d / 'ca.pem'), 'cert': str(d / 'node.pem'), 'key': str(d / 'node.key')}


def _refused_without_certificate(port: int, ca: str) -> bool:
    """A TLS client that trusts the CA but shows no certificate of its own: the scheduler
    must end the connection (an alert, or a closed socket) before a byte of Dask is read."""
    import ssl
    ctx = ssl.create_default_context(cafile=ca)
    try:
        with socket.create_connection(('127.0.0.1', port), timeout=5) as raw, \
                ctx.wrap_socket(raw, server_hostname='127.0.0.1') as conn:
            conn.sendall(b'\0' * 16)
            return conn.recv(1) == b''
    except (ssl.SSLError, ConnectionError):
        return True


def test_a_tls_cluster_runs_the_sweep_and_refuses_a_client_without_certificate(
        tmp_path: pathlib.Path) -> None:
    from distributed import Client
    from distributed.security import Security

    from pam_bench.cluster.errors import ClusterError
    from pam_bench.cluster.layer import TlsFiles
    certs = _certificates(tmp_path)
    tls = ['--tls-ca-file', certs['ca'], '--tls-cert', certs['cert'], '--tls-key',
           certs['key']]
    security = Security(tls_ca_file=certs['ca'], tls_client_cert=certs['cert'],
                        tls_client_key=certs['key'], require_encryption=True)
    with loopback_cluster(tmp_path, workers=2, nanny=False, tls=tls, security=security,
                          wait_s=40) as (address, _):
        port = int(address.rsplit(':', 1)[1])
        spec = tmp_path / 'sweep.yaml'
        spec.write_text(SWEEP)
        rows = run_sweep(load_sweep(spec), tmp_path / 'out',
                         {'scheduler': address, 'tls': TlsFiles(**certs)})
        assert len(rows) == 4 and all(r['status'] == 'ok' for r in rows)
        with pytest.raises((OSError, TimeoutError)):
            Client(address.replace('tls://', 'tcp://'), timeout='5s')      # no TLS at all
        assert _refused_without_certificate(port, certs['ca'])
        from pam_bench.cluster.layer import connect
        with pytest.raises(ClusterError, match='cannot reach the scheduler'):
            with connect(address.replace('tls://', 'tcp://')):
                pass
