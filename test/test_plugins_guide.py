"""docs/plugins.md's own code, run: its package declaration, its law (closed form, compiled,
a round trip through the fit's replay) and its controller (built and stepped as the servo
does), and the example package that follows it."""

from __future__ import annotations

import importlib.util
import pathlib
import re
import sys
import tomllib
import types

import numpy as np
import pytest

from pam_bench.control.params import TorqueServoParams
from pam_bench.control.plugins import problem as controller_problem
from pam_bench.models.laws.base import ForceLaw, law_function
from pam_bench.models.laws.zoo import problem as law_problem

ROOT = pathlib.Path(__file__).resolve().parents[1]
GUIDE = ROOT / 'docs' / 'plugins.md'


def _blocks(lang: str) -> list[str]:
    return re.findall(rf'```{lang}\n(.*?)```', GUIDE.read_text(encoding='utf-8'), re.S)


def _module(name: str, marker: str) -> types.ModuleType:
    """The guide's python block holding ``marker``, imported as module ``name``."""
    code = next(b for b in _blocks('python') if marker in b)
    module = types.ModuleType(name)
    sys.modules[name] = module         # dataclasses look their module up
    exec(compile(code, f'docs/plugins.md ({name})', 'exec'), module.__dict__)  # noqa: S102
    return module


@pytest.fixture(scope='module')
def laws() -> types.ModuleType:
    return _module('guide_laws', 'LinearBraidParams')


def test_the_package_declares_both_entry_points() -> None:
    project = tomllib.loads(_blocks('toml')[0])['project']
    eps = project['entry-points']
    assert eps['pam_bench.muscle_laws'] == {'linear_braid': 'lab_muscles.laws:LAW'}
    assert eps['pam_bench.controllers'] == {'pure_p': 'lab_muscles.controllers:PureP'}


def test_the_guides_law_is_its_closed_form_and_compiles(laws: types.ModuleType) -> None:
    law = laws.LAW
    assert isinstance(law, ForceLaw) and law_problem(law) == ''
    assert law.params == ('k_m2', 'x0_m')
    p = np.array([0.0, 3.0e5, 6.0e5, 6.0e5])
    x = np.array([0.0, 0.0, 0.05, 0.10])
    np.testing.assert_allclose(law.law(np.array(law.start), p, x, 0.35),
                               2.8e-3 * p * (1.0 - x / 0.10), rtol=1e-12, atol=1e-12)
    fast, why = law_function(law)
    assert why == '', why
    np.testing.assert_allclose(fast(np.array(law.start), p, x, 0.35),
                               law.law(np.array(law.start), p, x, 0.35), rtol=1e-12)


@pytest.fixture
def installed(tmp_path: pathlib.Path) -> dict[str, str]:
    """The guide's package as an installed distribution (its modules and its entry points'
    metadata on a path), and the environment that sees it."""
    import os
    pkg = tmp_path / 'lab_muscles'
    pkg.mkdir()
    (pkg / '__init__.py').write_text('')
    (pkg / 'laws.py').write_text(next(b for b in _blocks('python') if 'LinearBraidParams' in b))
    (pkg / 'controllers.py').write_text(next(b for b in _blocks('python')
                                             if 'class PureP' in b))
    meta = tmp_path / 'lab_muscles-0.1.0.dist-info'
    meta.mkdir()
    (meta / 'METADATA').write_text('Metadata-Version: 2.1\nName: lab-muscles\n'
                                   'Version: 0.1.0\n')
    eps = tomllib.loads(_blocks('toml')[0])['project']['entry-points']
    (meta / 'entry_points.txt').write_text(''.join(
        f'[{group}]\n' + ''.join(f'{k} = {v}\n' for k, v in items.items())
        for group, items in eps.items()))
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), str(ROOT)]))


def test_installed_it_is_listed_compiled_and_fits_back(installed: dict[str, str]) -> None:
    """``pam-bench plugins`` lists both, the law compiled; the round trip the guide gives
    (readings made with the law, ``calibrate --law``) recovers its parameters."""
    import subprocess
    out = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'plugins'], env=installed,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert re.search(r'muscle law +linear_braid +lab-muscles +ok, compiled', out.stdout), \
        out.stdout
    assert re.search(r'controller +pure_p +lab-muscles +ok', out.stdout), out.stdout
    script = """
import dataclasses, json
import numpy as np
from pam_bench.config.settings import LawSettings
from pam_bench.fit.calibrate_bags import calibrate_bags
from pam_bench.fit.calibrate_replay import Observations
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.quasistatic import QuasiStaticBench
laws = LawSettings()
laws = dataclasses.replace(laws, linear_braid=dataclasses.replace(
    laws.linear_braid, k_m2=2.2e-3, x0_m=0.13))
muscle = dataclasses.replace(MuscleParams(), kind='law', law='linear_braid')
qs = QuasiStaticBench(ValveParams(), muscle, overshoot=True, laws=laws)
readings = [('isometric', float(u), x, qs.hold_position(float(u), x).force_n)
            for x in (0.0, 0.03, 0.06)
            for u in [*np.arange(0.0, 6.01, 0.5), *np.arange(6.0, -0.01, -0.5)]]
res = calibrate_bags(Observations(readings, []), replay='static', law='linear_braid',
                     max_nfev=40)
print(json.dumps({k: v for k, v in res['values'].items() if k.startswith('linear_braid.')}))
"""
    fit = subprocess.run([sys.executable, '-c', script], env=installed, capture_output=True,
                         text=True, timeout=300)
    assert fit.returncode == 0, fit.stderr
    import json
    got = json.loads(fit.stdout.strip().splitlines()[-1])
    assert got['linear_braid.k_m2'] == pytest.approx(2.2e-3, rel=0.01)
    assert got['linear_braid.x0_m'] == pytest.approx(0.13, rel=0.01)


def test_the_guides_controller_builds_and_steps() -> None:
    ctl_module = _module('guide_controllers', 'class PureP')
    cls = ctl_module.PureP
    assert controller_problem(cls) == ''
    ctl = cls(cls.settings(), TorqueServoParams(), None)
    ctl.reset()
    ff, fb = ctl.step(0.001, (300.0, 0.0, 0.0), 0.04, 250.0)
    assert (ff, fb) == pytest.approx((2.5, 0.5))


def _example_laws() -> types.ModuleType:
    """The example package's ``laws.py``, loaded by its path."""
    path = ROOT / 'examples' / 'pam_bench_example' / 'pam_bench_example' / 'laws.py'
    spec = importlib.util.spec_from_file_location('pam_bench_example_laws', path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules['pam_bench_example_laws'] = module
    spec.loader.exec_module(module)
    return module


def test_the_example_package_follows_the_guide() -> None:
    """Its law compiles, as the guide says a law written so does."""
    module = _example_laws()
    assert law_function(module.LAW)[1] == ''


@pytest.mark.parametrize('pressure_pa', [0.0, 2.0e5, 6.0e5])
def test_the_example_law_is_continuous_and_solves_its_equation(pressure_pa: float) -> None:
    """The force the guide asks for ('What makes a law compile'): P(F, x / l0) = p where the
    muscle pulls, the stretched muscle on the branch that rises from F = 0 (tens of newtons of
    its own at p = 0, not the far root's kilonewtons) plus the braid's lock-up, and no jump as
    x moves by micrometres."""
    laws = _example_laws()
    th = np.array(laws.LAW.start, dtype=float)
    l0 = 0.35
    x = np.linspace(-0.02, 0.005, 4001)                     # 6.25 um apart
    f = laws.force(th, np.full(x.shape, pressure_pa), x, l0)
    assert np.abs(np.diff(f)).max() < 5.0     # N per 6.25 um (the lock-up alone: 0.68 N)
    own = f - th[7] * np.maximum(-x, 0.0)                   # the law's term, lock-up taken off
    pulls = own > 0.0
    solved = [laws._pressure(th, fi, xi / l0) for fi, xi in
              zip(own[pulls], x[pulls], strict=True)]
    np.testing.assert_allclose(solved, pressure_pa, atol=1e-3)
    if pressure_pa == 0.0:
        assert own[x < 0.0].max() < 100.0
