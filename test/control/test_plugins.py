"""Plug-ins, the Python way: the example package installed beside pam_bench adds a force law
and a controller that the twin, the nodes, servo-compare and run all use; a plug-in that
raises vents the servo with one line naming it and ends the run aborted, the bag valid; one
that cannot run is named before anything starts."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import textwrap

import pytest

from test.conftest import next_domain
from test.helpers import bag_messages

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / 'examples' / 'pam_bench_example'


def _pam_bench(site: pathlib.Path, *args: str, timeout: float = 120.0
               ) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(site), ROS_DOMAIN_ID=str(next_domain()),
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    return subprocess.run([sys.executable, '-m', 'pam_bench.cli', *args], env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope='module')
def site(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """The example package installed (pip, non-editable) into a folder of its own, put on
    the path of the commands below: beside pam_bench, the venv left as it was."""
    target = tmp_path_factory.mktemp('site')
    subprocess.run([sys.executable, '-m', 'pip', 'install', '-q', '--no-deps',
                    '--no-build-isolation', '--target', str(target), str(EXAMPLE)],
                   check=True, capture_output=True, timeout=300)
    return target


def test_plugins_lists_the_law_and_the_controller(site: pathlib.Path) -> None:
    out = _pam_bench(site, 'plugins')
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert any(ln.split()[:4] == ['muscle', 'law', 'hunt_graber_quinn', 'pam-bench-example']
               and ln.endswith('ok, compiled') for ln in lines), out.stdout
    assert any(ln.split()[:3] == ['controller', 'sliding_mode', 'pam-bench-example']
               and ln.endswith('ok') for ln in lines), out.stdout


@pytest.mark.parametrize('engine', ['twin', 'ros'])
def test_servo_compare_ranks_the_plugin_beside_the_builtins(site: pathlib.Path,
                                                           tmp_path: pathlib.Path,
                                                           engine: str) -> None:
    out = _pam_bench(site, 'servo-compare', '--engine', engine, '--controller',
                     'sliding_mode', '--scene', 'servo_sin_t', '--duration', '1.5', '--out',
                     str(tmp_path / 'sc'), '--workers', '1', timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    ranked = [ln.split()[1] for ln in out.stdout.splitlines() if ln.startswith('servo_sin_t')]
    assert 'sliding_mode' in ranked and 'dynamic_inverse_pid' in ranked, out.stdout
    assert len(ranked) == 6


def test_a_scene_runs_the_plugin_law(site: pathlib.Path, tmp_path: pathlib.Path) -> None:
    bag = tmp_path / 'bag'
    out = _pam_bench(site, 'run', 'demo', '--out', str(bag), '--set',
                     'muscle_1.muscle.kind=law', '--set', 'muscle_1.muscle.law=hunt_graber_quinn',
                     '--set', 'muscle_1.laws.hunt_graber_quinn.a5_pa_per_n=400.0')
    assert out.returncode == 0, out.stdout + out.stderr
    points = bag_messages(bag, '/protocol/point')
    assert len(points) == 24 and max(p.force for p in points) > 100.0
    unknown = _pam_bench(site, 'run', 'demo', '--out', str(tmp_path / 'b2'), '--set',
                         'muscle_1.laws.hunt_graber_quinn.a5_pa_per_m=400.0')
    assert unknown.returncode == 2 and "did you mean 'muscle_1.laws.hunt_graber_quinn." \
        "a5_pa_per_n'" in unknown.stderr, unknown.stderr


BROKEN = """
import dataclasses
from pam_bench.vocabulary.params import field


@dataclasses.dataclass
class Settings:
    after_s: float = field(0.5, 's', 'raise after this long', 0.0, 100.0)


class Broken:
    settings = Settings

    def __init__(self, settings, servo, inverse):
        self.t = 0.0
        self.after = settings.after_s

    def reset(self):
        pass

    def step(self, dt_s, target, contraction_m, force_n):
        self.t += dt_s
        if self.t > self.after:
            raise ZeroDivisionError('a lab bug')
        return 1.0, 0.0
"""


def _site_with(tmp_path: pathlib.Path, name: str, modules: dict[str, str],
               entry_points: str) -> pathlib.Path:
    """A folder holding a distribution ``name`` made of ``modules`` that declares
    ``entry_points`` (the text of its entry_points.txt): a plug-in package on the path."""
    site = tmp_path / 'site'
    info = site / f'{name}-0.1.dist-info'
    info.mkdir(parents=True)
    for module, text in modules.items():
        (site / f'{module}.py').write_text(textwrap.dedent(text))
    (info / 'METADATA').write_text(f'Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n')
    (info / 'entry_points.txt').write_text(entry_points)
    return site


def test_a_plugin_that_raises_vents_the_servo_and_ends_the_run_aborted(
        tmp_path: pathlib.Path) -> None:
    site = _site_with(tmp_path, 'broken-ctl', {'broken_ctl': BROKEN},
                      '[pam_bench.controllers]\nbroken = broken_ctl:Broken\n')
    bag = tmp_path / 'bag'
    out = _pam_bench(site, 'run', 'servo_sin_t', '--out', str(bag), '--set',
                     'torque_servo.controller=broken')
    assert out.returncode == 4, out.stdout + out.stderr
    assert "controller plug-in 'broken' raised ZeroDivisionError" in out.stdout + out.stderr
    states = bag_messages(bag, '/torque_servo/state')
    bad = [s for s in states if s.status]
    assert bad and "controller plug-in 'broken' raised ZeroDivisionError" in bad[0].status
    assert all(list(s.voltage) == [0.0, 0.0] for s in bad)        # vented
    assert len(bad) <= 2                                          # and the run ended there
    info = _pam_bench(site, 'info', str(bag))
    assert 'ended     aborted' in info.stdout, info.stdout


UNBUILDABLE = """
import dataclasses


@dataclasses.dataclass
class Settings:
    pass


class Unbuildable:
    settings = Settings

    def __init__(self, settings, servo, inverse):
        raise RuntimeError('needs a calibration file nobody gave')

    def reset(self):
        pass

    def step(self, dt_s, target, contraction_m, force_n):
        return 0.0, 0.0
"""


def test_plugins_that_cannot_run_are_named_before_anything_starts(
        tmp_path: pathlib.Path) -> None:
    """Issue 51: ``plugins`` builds each plug-in and calls one that cannot be built, or that
    does not import, not usable with the reason; a run naming it fails before any node."""
    site = _site_with(tmp_path, 'lab-broken', {'unbuildable': UNBUILDABLE,
                                               'bad_law': 'import not_installed_anywhere\n'},
                      '[pam_bench.controllers]\nunbuildable = unbuildable:Unbuildable\n'
                      '[pam_bench.muscle_laws]\nbad_law = bad_law:LAW\n')
    out = _pam_bench(site, 'plugins')
    assert out.returncode == 0, out.stderr
    rows = {ln.split()[2] if ln.startswith('muscle') else ln.split()[1]: ln
            for ln in out.stdout.splitlines()}
    assert 'not usable: cannot be built with its default settings: RuntimeError: needs a ' \
        'calibration file' in rows['unbuildable'], out.stdout
    assert "not usable: ModuleNotFoundError: No module named 'not_installed_anywhere'" in \
        rows['bad_law'], out.stdout
    bag = tmp_path / 'bag'
    run = _pam_bench(site, 'run', 'servo_sin_t', '--out', str(bag), '--set',
                     'torque_servo.controller=unbuildable')
    assert run.returncode == 2 and not bag.exists(), run.stdout + run.stderr
    assert "controller plug-in 'unbuildable' (package lab-broken): cannot be built with the " \
        "scene's settings: RuntimeError" in run.stderr, run.stderr
    law = _pam_bench(site, 'run', 'demo', '--out', str(bag), '--set', 'muscle_1.muscle.kind=law',
                     '--set', 'muscle_1.muscle.law=bad_law')
    assert law.returncode == 2 and not bag.exists(), law.stdout + law.stderr
    assert "force law 'bad_law': its plug-in (package lab-broken) cannot be used: " \
        'ModuleNotFoundError' in law.stderr, law.stderr
