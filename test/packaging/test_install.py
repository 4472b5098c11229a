"""The package installs like any other: a non-editable pip install into a fresh venv, and a
colcon workspace build; each then runs the bench from a folder outside the checkout.

The workspace is an overlay: colcon finds ``pam_bench`` (ament_python) and
``pam_bench_interfaces`` in the clone by their paths (no link), and builds ``pam_bench`` on top
of the ``pam_bench_interfaces`` that ``make setup`` built from ``msg_defs/`` with CMake into
.venv (the underlay): the workspace leaves the clone's interfaces package out
(``--packages-ignore``, from colcon-package-selection), whose CMake build runs on every fresh
machine in ``tools/bootstrap.sh``.

The fresh venv reaches the ROS 2 wheels and the other dependencies through a ``.pth`` line that
adds this project's .venv site-packages (``pip install --no-index`` proves nothing is
downloaded): what is under test is what ``pam_bench`` itself ships (nodes, config, scenes,
msg_defs), not the registry.
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import sysconfig

REPO = pathlib.Path(__file__).resolve().parents[2]
SITE = pathlib.Path(sysconfig.get_paths()['purelib'])
SHORT = REPO / 'test' / 'config_short.yaml'


def _venv_site(venv: pathlib.Path) -> pathlib.Path:
    ver = f'python{sys.version_info.major}.{sys.version_info.minor}'
    return venv / 'lib' / ver / 'site-packages'


def test_pip_install_runs_the_demo_from_anywhere(tmp_path: pathlib.Path,
                                                 ros_domain: int) -> None:
    venv = tmp_path / 'venv'
    # no pip of its own (ensurepip: 3 s): the .pth below lends it this venv's, which installs
    # into the running interpreter's prefix, the fresh venv
    subprocess.run([sys.executable, '-m', 'venv', '--without-pip', str(venv)], check=True)
    (_venv_site(venv) / 'zz_pam_bench_deps.pth').write_text(
        f'import site; site.addsitedir({str(SITE)!r})\n')
    py = venv / 'bin' / 'python'
    res = subprocess.run([str(py), '-m', 'pip', 'install', '-q', '--no-index',
                          '--no-build-isolation', str(REPO)],
                         capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    away = tmp_path / 'elsewhere'
    away.mkdir()
    where = subprocess.run([str(py), '-c', 'import pam_bench.nodes.valve_sim, pam_bench; '
                            'print(pam_bench.__file__)'],
                           capture_output=True, text=True, cwd=away, check=True).stdout
    assert where.startswith(str(venv)), where             # the installed copy, not the tree
    for script in ('pam-bench', 'valve_sim', 'sequencer', 'recorder'):
        assert (venv / 'bin' / script).exists(), script
    res = subprocess.run([str(venv / 'bin' / 'pam-bench'), 'run', 'demo', '--out', 'bag'],
                         capture_output=True, text=True, cwd=away, timeout=240)
    assert res.returncode == 0, res.stdout + res.stderr
    _check_bag(away / 'bag', 'demo', 24)
    _check_compiled_core([str(py), '-c', CORE], away, tmp_path / 'cache', str(venv))


CORE = ('from pam_bench.models import jit; jit.use("compiled"); '
        'print(jit.__file__, jit.cache_dir(), jit.enabled())')
"""Loads the compiled core in the installed copy and says where it is and where its cache is."""


def _check_compiled_core(cmd: list[str], cwd: pathlib.Path, cache: pathlib.Path,
                         installed: str, env: dict[str, str] | None = None) -> None:
    """The installed copy runs the compiled core, its numba cache outside the install (a
    wheel's or colcon's tree may be read-only): under ``$XDG_CACHE_HOME/pam_bench/numba``."""
    env = dict(env or os.environ, XDG_CACHE_HOME=str(cache))
    env.pop('NUMBA_CACHE_DIR', None)
    res = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd, env=env, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    module, where, enabled = res.stdout.split()[-3:]
    assert module.startswith(installed) and enabled == 'True', res.stdout
    assert where == str(cache / 'pam_bench' / 'numba')
    assert list((cache / 'pam_bench' / 'numba').rglob('*.nbi')), 'no numba cache index written'


def _check_bag(bag: pathlib.Path, scene: str, readings: int) -> None:
    """The bag holds what the installed nodes measured: every reading of the protocol, a
    muscle that pulls, and the run description of the installed copy."""
    import numpy as np

    from pam_bench.bags.baginfo import bag_info
    from pam_bench.bags.bagread import read_bags
    data = read_bags([str(bag)])
    (points,) = data.points.values()
    assert len(points) == readings
    assert np.all(np.isfinite(points.force_n)) and points.force_n.max() > 100.0
    info = bag_info(str(bag))
    assert info['run']['scene'] == scene and info['end']['state'] == 'done'


def test_colcon_workspace_builds_and_its_install_runs(tmp_path: pathlib.Path,
                                                      ros_domain: int) -> None:
    venv = pathlib.Path(sys.prefix)
    ws = tmp_path / 'ws'
    ws.mkdir()
    env = dict(os.environ, PATH=f'{venv / "bin"}{os.pathsep}{os.environ["PATH"]}',
               AMENT_PREFIX_PATH=str(venv), CMAKE_PREFIX_PATH=str(venv))
    # the clone as it is, no link made by hand: colcon finds both packages by their paths
    # (README); pam_bench is built over the interfaces of the underlay (module docstring)
    paths = ['--base-paths', str(REPO), str(REPO / 'msg_defs')]
    assert _colcon_finds(paths[1:]) == ['pam_bench', 'pam_bench_interfaces']
    res = subprocess.run([str(venv / 'bin' / 'colcon'), 'build', *paths,
                          '--packages-ignore', 'pam_bench_interfaces', '--cmake-args',
                          f'-DPython3_EXECUTABLE={sys.executable}', '-DBUILD_TESTING=OFF'],
                         capture_output=True, text=True, cwd=ws, env=env, timeout=400)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-3000:]
    install = ws / 'install'
    assert not (install / 'pam_bench_interfaces').exists()     # the underlay's, not rebuilt
    assert (install / 'pam_bench' / 'share' / 'pam_bench' / 'config' / 'bench.yaml').exists()
    away = tmp_path / 'elsewhere'
    away.mkdir()
    script = (f'. {install / "setup.sh"} && python -c "import pam_bench; '
              f'print(pam_bench.__file__)" && {install / "pam_bench/lib/pam_bench/pam-bench"}'
              f' run {SHORT} --out bag')
    res = subprocess.run(['bash', '-c', script], capture_output=True, text=True, cwd=away,
                         env=env, timeout=240)
    assert res.returncode == 0, res.stdout + res.stderr
    assert res.stdout.startswith(str(install / 'pam_bench')), res.stdout   # the built copy
    _check_bag(away / 'bag', 'config_short', 8)
    _check_compiled_core(['bash', '-c', f'. {install / "setup.sh"} && python -c \'{CORE}\''],
                         away, tmp_path / 'cache', str(install / 'pam_bench'), env)


def _colcon_finds(base_paths: list[str]) -> list[str]:
    """The packages colcon discovers under ``base_paths`` (what ``colcon list`` prints)."""
    import argparse

    from colcon_core.package_discovery import add_package_discovery_arguments, discover_packages
    from colcon_core.package_identification import get_package_identification_extensions
    parser = argparse.ArgumentParser()
    add_package_discovery_arguments(parser)
    args = parser.parse_args(['--base-paths', *base_paths])
    return sorted(d.name for d in discover_packages(args, get_package_identification_extensions()))
