"""The compiled core against the pure-Python reference it replaces: bit-equal, case by case.

Every comparison runs the same objects twice, once per core, from identical copies, and
compares with ``==`` (``assert_array_equal``): the compiled kernels repeat the reference's
floating-point operations in its order, so nothing is allowed to differ.
"""

from __future__ import annotations

import copy
import dataclasses
import pathlib
from typing import Any

import numpy as np
import pytest

from pam_bench.models import jit
from pam_bench.models.coupling import SETTLE_OFF, SettleParams, solve_substeps, substep_grid
from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.valve import ValveModel, ValveParams


def _both(fn):  # run fn() under each core on fresh copies; return (python, compiled)
    out = []
    for core in ('python', 'compiled'):
        jit.use(core)
        out.append(fn())
    return out


def _state(muscle: MuscleModel, drive: LoadingServoModel) -> tuple:
    return (muscle.friction.z, muscle.friction.sticking, drive.phi, drive.w, drive.integral,
            drive.force_n, drive.encoder_rad, drive.contraction_m, drive.torque,
            drive.saturated)


def _run(muscle: MuscleModel, drive: LoadingServoModel, pressures: np.ndarray,
         d: float = 0.005, force: float = 0.0, settle: SettleParams = SETTLE_OFF) -> tuple:
    m, dr = copy.deepcopy(muscle), copy.deepcopy(drive)
    res = solve_substeps(m, dr, [d] * len(pressures), list(pressures), force, settle)
    return (res.forces_n, res.contractions_m, res.stiffness_n_per_m, res.friction_n,
            res.iterations, _state(m, dr), res.held)


def _drive(mode: LoadMode, setpoint: float, x0: float = 0.0, **kw: object
           ) -> LoadingServoModel:
    d = LoadingServoModel(LoadingServoParams(**kw))  # type: ignore[arg-type]
    d.reset(x0)
    d.command(mode, setpoint)
    return d


def _ramp(*points: float, n: int = 120) -> np.ndarray:
    """Pressures (Pa) through the given points, n sub-steps per leg."""
    return np.concatenate([np.linspace(a, b, n) for a, b in zip(points[:-1], points[1:],
                                                                      strict=True)])


CASES = {
    # isometric: the position loop holds x while the pressure rises and falls (friction turns)
    'position hold, up and down': (MuscleParams(), (LoadMode.POSITION, 0.04, 0.04),
                                   _ramp(0.0, 6e5, 1e5, 4e5)),
    # isotonic: the force loop lets the muscle contract and stretch back
    'force hold, light load': (MuscleParams(), (LoadMode.FORCE, 50.0, 0.0),
                               _ramp(0.0, 6e5, 0.0)),
    # a heavy load on a deflated muscle: stretched below nominal length, the braid locks up
    'lock-up under a heavy load': (MuscleParams(), (LoadMode.FORCE, 900.0, 0.0),
                                   _ramp(0.0, 2e5, 0.0)),
    # friction turning points, many small reversals at a held position
    'friction reversals': (MuscleParams(), (LoadMode.POSITION, 0.02, 0.02),
                           _ramp(2e5, 2.4e5, 2.1e5, 2.3e5, 2.15e5, 2.25e5, n=40)),
    'no hysteresis': (MuscleParams(hysteresis=False), (LoadMode.FORCE, 300.0, 0.0),
                      _ramp(0.0, 5e5, 1e5)),
    'drive off': (MuscleParams(), (LoadMode.OFF, 0.0, 0.03), _ramp(1e5, 4e5)),
    'sharp threshold (w = 0)': (MuscleParams(threshold_width_pa=0.0),
                                (LoadMode.FORCE, 100.0, 0.0), _ramp(0.0, 3e5, 5e4)),
}


@pytest.mark.parametrize('settle', [SETTLE_OFF, SettleParams()], ids=['every', 'settled'])
@pytest.mark.parametrize('name', list(CASES))
def test_coupled_sub_steps_are_bit_equal(name: str, settle: SettleParams) -> None:
    params, (mode, sp, x0), pressures = CASES[name]
    muscle, drive = MuscleModel(params), _drive(mode, sp, x0)
    muscle.reset(x0, float(pressures[0]))
    py, nb = _both(lambda: _run(muscle, drive, pressures, settle=settle))
    for a, b in zip(py, nb, strict=True):
        np.testing.assert_array_equal(np.asarray(a, dtype=object), np.asarray(b, dtype=object))


@pytest.mark.parametrize('dynamics', [True, False])
@pytest.mark.parametrize('d', [1e-3, 5e-3, 0.1, 3.0])
def test_any_sub_step_length_and_the_ideal_holder(dynamics: bool, d: float) -> None:
    muscle = MuscleModel()
    drive = _drive(LoadMode.FORCE, 200.0, 0.0, dynamics=dynamics)
    py, nb = _both(lambda: _run(muscle, drive, _ramp(0.0, 4e5, n=20), d=d))
    assert py == nb


def test_speed_limit_and_end_stop_are_bit_equal() -> None:
    """A slack muscle and a force set value far above it: the drive runs at its speed limit
    into the end of its travel."""
    muscle = MuscleModel()
    drive = _drive(LoadMode.FORCE, 2000.0, 0.0)
    py, nb = _both(lambda: _run(muscle, drive, np.full(400, 1e4)))
    assert py == nb


@pytest.mark.parametrize('voltage', [0.0, 3.0, 10.0, 12.0])
def test_valve_samples_are_bit_equal_clamp_included(voltage: float) -> None:
    """12 V is beyond the range (clamped to 10 V, 1 MPa); 0 V from a high state overshoots
    below atmosphere, where the report clamps at 0."""
    steps = substep_grid(0.503, 0.005) + [1e-3] * 7 + [0.2] + [0.005] * 3   # a length again

    def go() -> tuple:
        v = ValveModel(ValveParams(damping_ratio=0.1))
        v.reset(8e5 if voltage == 0.0 else 0.0)
        out = v.samples(voltage, steps, 1.0e-4)
        return out, v.state.tolist()
    py, nb = _both(go)
    assert py == nb
    assert min(py[0]) >= 0.0 and max(py[0]) <= ValveParams().pressure_max_pa


def test_a_whole_protocol_is_bit_equal() -> None:
    """isometric_quick and step records on the twin: every reading and sample equal."""
    from pam_bench.twin.protocol_run import run_protocol

    def go() -> tuple:
        iso = run_protocol('isometric_quick', 3.0)
        step = run_protocol('step_response_quick', 3.0, overrides={
            'x_m': [0.0, 0.04, 0.04]})
        return ([dataclasses.astuple(p.measurement) for p in iso.points + step.points],
                [r.samples for r in step.records], iso.substeps + step.substeps)
    py, nb = _both(go)
    assert py == nb
    assert len(py[1]) > 0


def test_a_non_finite_pressure_is_one_error_in_both() -> None:
    from pam_bench.models.errors import ModelError
    for core in ('python', 'compiled'):
        jit.use(core)
        with pytest.raises(ModelError, match='not finite'):
            solve_substeps(MuscleModel(), _drive(LoadMode.OFF, 0.0), [0.005, 0.005],
                           [1e5, float('nan')], 0.0)


def test_the_core_asked_for_is_known_before_it_loads(monkeypatch: pytest.MonkeyPatch) -> None:
    """``core`` is what was asked, ``enabled`` whether it runs yet: before the kernels load,
    the reference runs, yet the core to restore after a switch is still 'compiled'."""
    import threading
    jit.use('compiled')
    monkeypatch.setattr(jit, '_READY', threading.Event())     # not loaded yet
    assert not jit.enabled()
    assert jit.core() == 'compiled'
    monkeypatch.undo()
    jit.use('python')
    assert jit.core() == 'python' and not jit.enabled()
    jit.use('compiled')
    assert jit.core() == 'compiled' and jit.enabled()


def test_the_cache_lives_where_the_install_can_write() -> None:
    import os
    assert os.environ['NUMBA_CACHE_DIR'] == str(jit.cache_dir())
    assert jit.warm_up() >= 0.0


@pytest.mark.parametrize('mode, sp', [(LoadMode.FORCE, 300.0), (LoadMode.POSITION, 0.05),
                                      (LoadMode.OFF, 0.0)])
def test_the_drive_replay_is_bit_equal(mode: LoadMode, sp: float) -> None:
    """The loading-servo node replays the muscle's sub-steps (``replay``): the same state as
    the muscle node's copy of the drive after its coupled solve."""
    forces = list(np.concatenate([np.linspace(0.0, 600.0, 300), np.linspace(600.0, 20.0, 200)]))
    steps = [0.005] * 250 + [0.001] * 250

    def go() -> tuple:
        d = _drive(mode, sp, 0.03)
        out = d.replay(steps, forces)
        return dataclasses.astuple(out), _state(MuscleModel(), d)
    py, nb = _both(go)
    assert py == nb


@pytest.mark.parametrize('name', list(CASES))
def test_the_kernels_interpreted_are_the_compiled_ones(name: str,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """One source: the kernels run by the interpreter (nothing compiled in) give the compiled
    results and the reference's, bit for bit."""
    params, (mode, sp, x0), pressures = CASES[name]
    muscle, drive = MuscleModel(params), _drive(mode, sp, x0)
    muscle.reset(x0, float(pressures[0]))
    py, nb = _both(lambda: _run(muscle, drive, pressures, settle=SettleParams()))
    jit.use('compiled')
    monkeypatch.setattr(jit, '_COMPILED', {})          # the same functions, interpreted
    interpreted = _run(muscle, drive, pressures, settle=SettleParams())
    for a, b, c in zip(py, nb, interpreted, strict=True):
        np.testing.assert_array_equal(np.asarray(a, dtype=object), np.asarray(c, dtype=object))
        np.testing.assert_array_equal(np.asarray(b, dtype=object), np.asarray(c, dtype=object))


EXAMPLE_LAW = (pathlib.Path(__file__).parents[2] / 'examples' / 'pam_bench_example'
               / 'pam_bench_example' / 'laws.py')


def _import_as(name: str, path: object) -> object:
    import importlib.util
    import sys
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def test_a_file_cached_under_another_module_name_is_cached_again(
        tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A lab's law file compiled under one module name (a test importing it by path), then
    under its package's name: the second finds numba's entry for the file unloadable (its
    module cannot be imported), writes it again, and a third compile loads it from the cache.
    Before, the entry was bypassed and every run compiled the law anew."""
    import subprocess
    import sys

    import numba
    monkeypatch.setenv('NUMBA_CACHE_DIR', str(tmp_path / 'cache'))
    monkeypatch.setattr(numba.config, 'CACHE_DIR', numba.config.CACHE_DIR)  # restored after
    law = tmp_path / 'lab_law.py'                     # the example plug-in's law, as a lab's
    law.write_text(EXAMPLE_LAW.read_text())
    first = subprocess.run([sys.executable, '-c', (
        'import importlib.util, sys, numpy as np\n'
        'from pam_bench.models import jit\n'
        f'spec = importlib.util.spec_from_file_location("lab_law_by_path", {str(law)!r})\n'
        'm = importlib.util.module_from_spec(spec); sys.modules[spec.name] = m\n'
        'spec.loader.exec_module(m)\n'
        'ex = (np.array(m.LAW.start, dtype=float), np.linspace(0.0, 6.0e5, 4), np.zeros(4), '
        '0.35)\n'
        'print(jit.compile_function(m.force, ex)[0].stats.cache_path is not None)\n')],
        capture_output=True, text=True, timeout=120)
    assert first.stdout.strip() == 'True', first.stdout + first.stderr   # cached there
    second: Any = _import_as('lab_package_law', law)
    example = (np.array(second.LAW.start, dtype=float), np.linspace(0.0, 6.0e5, 4),
               np.zeros(4), 0.35)
    fast, why = jit.compile_function(second.force, example)
    assert fast is not None and why == ''
    assert fast.stats.cache_path is not None, 'compiled without the cache'
    third: Any = _import_as('lab_package_law', law)     # a later run
    again, _ = jit.compile_function(third.force, example)
    assert again is not None and sum(again.stats.cache_hits.values()) == 1
    np.testing.assert_allclose(again(*example), second.force(*example), rtol=1e-15)


def test_the_core_loads_without_scipy_linalg_and_coverage() -> None:
    """numba's BLAS probe answered no while the core loads, and numba imported without
    ``coverage`` (``models.jit`` docstring): neither module imported; a function of ``np.dot``
    of 1-D arrays compiles as numba's loop, and ``np.linalg`` still finds LAPACK through
    SciPy."""
    import subprocess
    import sys
    code = ('import sys, numpy as np\n'
            'from pam_bench.models import jit\n'
            'jit.use("compiled")\n'
            'print("scipy.linalg" in sys.modules, "coverage" in sys.modules)\n'
            'import numba\n'
            'print(numba.njit(lambda a, b: np.dot(a, b))(np.arange(3.0), np.arange(3.0)))\n'
            'print(numba.njit(lambda a: np.linalg.det(a))(np.array([[2.0, 1.0], [1.0, 3.0]])))\n')
    res = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr
    linalg, coverage, dot, det = res.stdout.split()
    assert (linalg, coverage) == ('False', 'False')
    np.testing.assert_allclose([float(dot), float(det)], [5.0, 5.0], rtol=1e-12)
