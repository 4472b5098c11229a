"""Two benches side by side in one domain under two namespaces: their bags do not mix."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

from pam_bench.bags.bagread import read_bags
from test.bringup.test_wallclock import SETTLED

pytestmark = pytest.mark.wallclock


def _run(scene: pathlib.Path, out: pathlib.Path, namespace: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'run', str(scene),
                             '--wallclock', '--namespace', namespace, '--out', str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def test_two_benches_in_one_domain_keep_their_bags_apart(tmp_path: pathlib.Path,
                                                        ros_domain: int) -> None:
    scene = tmp_path / 'settled.yaml'
    scene.write_text(SETTLED)
    procs = {ns: _run(scene, tmp_path / ns, f'/{ns}') for ns in ('bench_a', 'bench_b')}
    try:
        outs = {ns: p.communicate(timeout=60)[0] for ns, p in procs.items()}
    finally:
        for p in procs.values():
            if p.poll() is None:
                p.kill()
    for ns, p in procs.items():
        assert p.returncode == 0, outs[ns]
        names = [line.split()[1] for line in (tmp_path / ns / 'metadata.yaml').read_text()
                 .splitlines() if line.strip().startswith('name: /')]
        assert names and all(n.startswith(f'/{ns}/') for n in names), names
        assert f'/{ns}/protocol/point' in names and f'/{ns}/diagnostics' in names
        data = read_bags([tmp_path / ns])           # the analysis reads a namespaced bag
        assert len(data.points['isometric_quick'].force_n) == 6
