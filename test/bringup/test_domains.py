"""Two runs in one exported ROS domain never mix: the domain leases (``bringup.domains``), and
two lock-step runs and a sweep at once, each as it would be alone."""

from __future__ import annotations

import csv
import os
import pathlib
import subprocess
import sys
import textwrap

import pytest

from pam_bench.bringup.domains import LEASE_DIR_ENV, private_domain, shared_domain
from pam_bench.bringup.errors import DomainInUseError


@pytest.fixture
def leases(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> pathlib.Path:
    """A lease folder of this test's own."""
    path = tmp_path / 'leases'
    monkeypatch.setenv(LEASE_DIR_ENV, str(path))
    return path


def test_a_second_lock_step_run_moves_to_a_free_domain(leases: pathlib.Path,
                                                       capsys: pytest.CaptureFixture) -> None:
    with private_domain(42) as first, private_domain(42) as second, private_domain(42) as third:
        assert (first, second, third) == (42, 43, 44)
    err = capsys.readouterr().err
    assert 'ROS_DOMAIN_ID 42 is in use by another pam_bench run (pid' in err
    assert 'this lock-step run uses domain 43' in err
    with private_domain(42) as again:         # released: free again, and no file left
        assert again == 42
    assert not list(leases.iterdir())


def test_a_wall_clock_node_name_is_leased_in_its_namespace(leases: pathlib.Path) -> None:
    with shared_domain(42, '', ['recorder', 'valve_1']):
        with pytest.raises(DomainInUseError, match=r'node valve_1 already runs in '
                           r'ROS_DOMAIN_ID 42, the root namespace \(pid \d+'):
            with shared_domain(42, '', ['valve_1']):
                pass
        with shared_domain(42, '/bench_b', ['recorder', 'valve_1']):   # another namespace
            with shared_domain(43, '', ['valve_1']):                     # another domain
                pass
        with shared_domain(42, '', ['load_cell_1']):    # a device the first does not run
            pass
        with pytest.raises(DomainInUseError, match='in use by a wall-clock|in use by'):
            with private_domain(42, quiet=True) as d:   # lock-step moves on, never joins
                assert d != 42
                raise DomainInUseError('in use by')
    assert not list(leases.iterdir())


def test_a_wall_clock_run_is_refused_a_domain_a_lock_step_run_holds(leases: pathlib.Path
                                                                    ) -> None:
    with private_domain(42), pytest.raises(DomainInUseError, match='lock-step run'):
        with shared_domain(42, '', ['recorder']):
            pass


def test_a_killed_holder_leaves_its_lease_to_the_next(leases: pathlib.Path) -> None:
    code = textwrap.dedent("""
        import os, sys, time
        from pam_bench.bringup.domains import private_domain
        with private_domain(42):
            print('held', flush=True)
            time.sleep(60)
    """)
    proc = subprocess.Popen([sys.executable, '-c', code], stdout=subprocess.PIPE, text=True,
                            env={**os.environ, LEASE_DIR_ENV: str(leases)})
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == 'held'
        with private_domain(42, quiet=True) as d:
            assert d == 43
        proc.kill()
        proc.wait(timeout=10)
        with private_domain(42, quiet=True) as d:
            assert d == 42
    finally:
        if proc.poll() is None:
            proc.kill()


SWEEP = textwrap.dedent("""\
    description: two demo runs through the nodes
    scene: demo
    engine: ros
    seeds: [0, 1]
    figures: [readings.force_max_N, run.exit_code]
""")


def _pam_bench(*args: str, env: dict[str, str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def test_two_runs_and_a_sweep_in_one_exported_domain_stay_apart(tmp_path: pathlib.Path,
                                                                 ros_domain: int) -> None:
    """Issue 51: each bag (and each sweep row) equals the same run done alone; the sweep's
    workers are pinned to the very domain the runs have (``PAM_BENCH_DOMAINS``)."""
    from pam_bench.bags.bagdiff import diff_bags
    from pam_bench.bags.bagread import read_bags
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_domain),
           'PAM_BENCH_DOMAINS': str(ros_domain)}
    sweep = tmp_path / 'two.yaml'
    sweep.write_text(SWEEP)
    procs = [_pam_bench('run', 'demo', '--processes', '--out', str(tmp_path / name), env=env)
             for name in ('a', 'b')]
    procs.append(_pam_bench('sweep', str(sweep), '--out', str(tmp_path / 'sweep'),
                            '--workers', '2', env=env))
    try:
        outs = [p.communicate(timeout=240)[0] for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    for p, out in zip(procs, outs, strict=True):
        assert p.returncode == 0, out
    alone = _pam_bench('run', 'demo', '--out', str(tmp_path / 'alone'), env=env)
    assert alone.wait(timeout=120) == 0
    for name in ('a', 'b'):
        rows = diff_bags(tmp_path / 'alone', tmp_path / name)
        demo = rows['demo']
        assert (demo['matched'], demo['only_a'], demo['only_b']) == (24, 0, 0), (name, rows)
        assert max(v for k, v in demo.items() if k.startswith('max_')) == 0.0, (name, rows)
    with open(tmp_path / 'sweep' / 'results.csv', newline='', encoding='utf-8') as fh:
        results = {int(r['seed']): r for r in csv.DictReader(fh)}
    force = float(read_bags([tmp_path / 'alone']).points['demo'].force_n.max())
    assert results[0]['status'] == 'ok' and float(results[0]['run.exit_code']) == 0
    assert float(results[0]['readings.force_max_N']) == pytest.approx(force, abs=1e-9)


FOREIGN_CLOCK = textwrap.dedent("""
    import rclpy
    from rosgraph_msgs.msg import Clock
    rclpy.init()
    node = rclpy.create_node('lab_clock')
    pub = node.create_publisher(Clock, '/clock', 10)
    node.create_timer(0.1, lambda: pub.publish(Clock()))
    print('publishing', flush=True)
    rclpy.spin(node)
""")


def test_a_foreign_clock_in_the_domain_stops_the_run_naming_it(tmp_path: pathlib.Path,
                                                               ros_domain: int) -> None:
    """A node no pam_bench run started (no lease) publishes /clock: the run stops, exit 4."""
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_domain)}
    other = subprocess.Popen([sys.executable, '-c', FOREIGN_CLOCK], env=env,
                             stdout=subprocess.PIPE, text=True)
    try:
        assert other.stdout is not None and other.stdout.readline().strip() == 'publishing'
        run = _pam_bench('run', 'demo', '--processes', '--out', str(tmp_path / 'bag'), env=env)
        out = run.communicate(timeout=120)[0]
    finally:
        other.kill()
        other.wait()
    assert run.returncode == 4, out
    assert 'another node publishes /clock in ROS_DOMAIN_ID' in out and '/lab_clock' in out, out
    assert 'Traceback' not in out, out
