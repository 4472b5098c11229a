"""The wheel alone: built from the clone, installed into a clean venv with the ROS 2 wheels and
nothing else, it reads, repairs and extracts a bag (issue 45 item 7).

Nothing of the development venv is visible in the clean one (no ``.pth`` line, no
``PYTHONPATH``): every import the three verbs need must come from what the wheel declares
(``install_requires``) or the ROS runtime wheels (``tools/ros_wheels.txt``). ``uv`` installs
from its cache (``make setup`` filled it) and reaches the registry only for what the cache
lacks.
"""

from __future__ import annotations

import os
import pathlib
import shutil
import subprocess
import sys

from pam_bench.bags.bagwrite import write_bag

REPO = pathlib.Path(__file__).resolve().parents[2]


def _ros_runtime_wheels() -> list[str]:
    """The runtime block of tools/ros_wheels.txt (not the build of msg_defs)."""
    lines = (REPO / 'tools' / 'ros_wheels.txt').read_text(encoding='utf-8').splitlines()
    out: list[str] = []
    for line in lines[lines.index(next(ln for ln in lines if ln.startswith('# Runtime'))) + 1:]:
        if line.startswith('# Build'):
            break
        if line.strip() and not line.startswith('#'):
            out.append(line.strip())
    return out


def _install(venv: pathlib.Path, wheel: pathlib.Path) -> None:
    uv = pathlib.Path(sys.executable).parent / 'uv'
    py = venv / 'bin' / 'python'
    if uv.exists() or shutil.which('uv'):
        uv_cmd = str(uv) if uv.exists() else 'uv'
        subprocess.run([uv_cmd, 'venv', '-q', '--python', sys.executable, str(venv)],
                       check=True)
        cmd = [uv_cmd, 'pip', 'install', '-q', '--python', str(py),
               *_ros_runtime_wheels(), str(wheel)]
        if subprocess.run([*cmd, '--offline'], capture_output=True).returncode != 0:
            subprocess.run(cmd, check=True)          # what the cache lacks, from the registry
        return
    subprocess.run([sys.executable, '-m', 'venv', str(venv)], check=True)
    subprocess.run([str(py), '-m', 'pip', 'install', '-q', '--disable-pip-version-check',
                    *_ros_runtime_wheels(), str(wheel)], check=True)


def _clone(to: pathlib.Path) -> pathlib.Path:
    """The tracked files of the clone, copied (the wheel builds there, not in the clone)."""
    files = subprocess.run(['git', '-C', str(REPO), 'ls-files', '-z'], check=True,
                           capture_output=True, text=True).stdout.split('\0')
    for name in filter(None, files):
        src = REPO / name
        if src.is_file():
            (to / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, to / name)
    return to


def test_the_wheel_alone_reads_repairs_and_extracts_a_bag(tmp_path: pathlib.Path) -> None:
    dist = tmp_path / 'dist'
    subprocess.run([sys.executable, '-m', 'pip', 'wheel', '-q', '--no-deps',
                    '--no-build-isolation', '--disable-pip-version-check', '-w', str(dist),
                    str(_clone(tmp_path / 'src'))], check=True, capture_output=True)
    wheel = next(dist.glob('pam_bench-*.whl'))
    import zipfile
    tops = {n.split('/')[0] for n in zipfile.ZipFile(wheel).namelist()}
    assert not {t for t in tops if t in ('benchmarks', 'test', 'tools')}, tops  # the clone's
    venv = tmp_path / 'venv'
    _install(venv, wheel)
    bag = tmp_path / 'bag'
    write_bag(bag, [{'protocol': 'isometric', 'series': 0, 'step': k, 'direction': 0,
                     'series_value': 0.0, 'set_value': 1.0e5 * k, 'voltage': float(k),
                     'force': 100.0 * k, 'contraction': 0.0, 'pressure': 1.0e5 * k}
                    for k in range(6)])
    env = {k: v for k, v in os.environ.items() if k != 'PYTHONPATH'}
    where = subprocess.run([str(venv / 'bin' / 'python'), '-c',
                            'import pam_bench; print(pam_bench.__file__)'], cwd=tmp_path,
                           env=env, capture_output=True, text=True, check=True).stdout
    assert str(venv) in where and str(REPO) not in where, where
    tool = str(venv / 'bin' / 'pam-bench')

    def run(*args: str) -> str:
        res = subprocess.run([tool, *args], cwd=tmp_path, env=env, capture_output=True,
                             text=True, timeout=300)
        assert res.returncode == 0, res.stdout + res.stderr
        return res.stdout

    assert '/protocol/point' in run('info', str(bag))
    assert 'nothing to repair' in run('bag-repair', str(bag))
    run('extract', str(bag), '--out', str(tmp_path / 'out'))
    assert (tmp_path / 'out' / 'summary.json').is_file()
