"""The compiled series of holds and steps (``twin.bench_holds``) against the Python bench's
exchanges it replaces (``SingleMuscleBench.run`` / ``step``), and where it steps aside."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pam_bench.models import jit
from pam_bench.models.coupling import SETTLE_OFF
from pam_bench.models.loading_servo import LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.bench import SingleMuscleBench
from pam_bench.twin.bench_holds import run_holds, run_steps

PHASES = ((1.0, 1.0, 1e-3), (2.0, 3.0, 5e-3))
# an isometric series up and down, an isotonic pair, the isometric series again: the
# friction's path, mode changes (the integral reset) and long settled spans
HOLDS = ([(u, LoadMode.POSITION, 0.03) for u in (0.0, 1.0, 2.5, 4.0, 2.0, 0.5)]
         + [(3.0, LoadMode.FORCE, 200.0), (3.0, LoadMode.FORCE, 50.0)]
         + [(u, LoadMode.POSITION, 0.06) for u in (1.0, 3.0)])
POSITION = [m == LoadMode.POSITION for _, m, _ in HOLDS]


def _twin(valve: ValveParams | None = None, muscle: MuscleParams | None = None
          ) -> SingleMuscleBench:
    return SingleMuscleBench(valve or ValveParams(), muscle or MuscleParams(),
                             LoadCellParams(noise=False), settle=SETTLE_OFF)


def _python_holds(twin: SingleMuscleBench) -> np.ndarray:
    out = []
    for (u, mode, value), pos in zip(HOLDS, POSITION, strict=True):
        twin.command_valve(u)
        twin.command_load(mode, value)
        for duration, h_s, sub in PHASES:
            twin.sub_step_s = sub
            twin.run(duration, h_s)
        out.append(twin.f if pos else twin.servo.angle * twin.servo.r)
    return np.array(out)


def _state(twin: SingleMuscleBench) -> tuple:
    return (twin.t, twin.p, twin.f, twin.x, twin.volume, twin._request, twin.u,
            *twin.valve.state, *twin.servo.state, int(twin.servo.mode), twin.servo.setpoint,
            *twin.muscle.friction.z, *twin.muscle.friction.sticking, twin.evidence.change_rel,
            twin.evidence.span_s)


@pytest.fixture(autouse=True)
def _compiled_core() -> None:
    jit.use('compiled')


@pytest.mark.parametrize('valve', [ValveParams(), ValveParams(damping_ratio=0.2,
                                                               natural_frequency_rad_s=40.0)],
                         ids=['004', 'slow, ringing'])
def test_holds_take_the_python_benchs_exchanges(valve: ValveParams) -> None:
    """Every hold's value, the exchanges and sub-steps taken and the whole state after them:
    equal to rounding (the Python valve's ZOH cache keys w to 1e-9 rad/s)."""
    fast, ref = _twin(valve), _twin(valve)
    out = run_holds(fast, HOLDS, PHASES, POSITION)
    want = _python_holds(ref)
    assert out is not None
    np.testing.assert_allclose(out, want, rtol=1e-9, atol=1e-9)
    assert (fast.steps, fast.substeps) == (ref.steps, ref.substeps)
    np.testing.assert_allclose(_state(fast), _state(ref), rtol=1e-9, atol=1e-12)


def test_steps_take_the_python_benchs_exchanges() -> None:
    """A valve step at a held end, then fixed exchanges (a step record's replay)."""
    fast, ref = _twin(), _twin()
    for twin in (fast, ref):
        run_holds(twin, [(1.0, LoadMode.POSITION, 0.02)], PHASES, [True])
        twin.command_valve(4.0)
        twin.sub_step_s = 1e-4
    out = run_steps(fast, 50, 0.01, 1e-4)
    want = []
    for _ in range(50):
        ref.step(0.01)
        want.append(ref.f)
    assert out is not None
    np.testing.assert_allclose(out, want, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(_state(fast), _state(ref), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize('case', ['reference core', 'order 0 valve', 'order 1 valve',
                                  'law muscle', 'nan voltage', 'nan set value'])
def test_what_it_does_not_run_is_left_to_the_python_bench(case: str) -> None:
    """None, and the twin untouched: the caller steps in Python, which says why."""
    valve, muscle, holds = ValveParams(), MuscleParams(), list(HOLDS[:2])
    if case.startswith('order'):
        valve = ValveParams(order=int(case[6]))
    elif case == 'law muscle':
        muscle = dataclasses.replace(muscle, kind='law', law='tondu_lopez')
    elif case == 'nan voltage':
        holds[1] = (float('nan'), LoadMode.POSITION, 0.03)
    elif case == 'nan set value':
        holds[1] = (1.0, LoadMode.FORCE, float('nan'))
    twin = _twin(valve, muscle)
    before = (twin.t, twin.f, twin.steps)
    try:
        if case == 'reference core':
            jit.use('python')
        assert run_holds(twin, holds, PHASES, [True, True]) is None
        if not case.startswith('nan'):
            assert run_steps(twin, 3, 0.01, 1e-3) is None
    finally:
        jit.use('compiled')
    assert (twin.t, twin.f, twin.steps) == before


def test_every_module_compiled_into_it_keys_the_cache() -> None:
    """numba checks only the file of the function it caches: every module whose functions
    ``hold_series`` and ``step_series`` call is in ``jit.KERNEL_MODULES`` (its sources key
    the cache), so a change there compiles them again."""
    import types

    from pam_bench.twin import bench_holds

    done: set[types.FunctionType] = set()

    def walk(fn: types.FunctionType) -> None:
        if fn in done:
            return
        done.add(fn)
        for name in fn.__code__.co_names:
            obj = fn.__globals__.get(name)
            if isinstance(obj, types.FunctionType):
                walk(obj)
    for fn in (bench_holds.hold_series, bench_holds.step_series):
        walk(fn)
    modules = {fn.__module__ for fn in done}
    assert modules - {bench_holds.__name__} <= set(jit.KERNEL_MODULES), modules
    assert {'pam_bench.models.valve', 'pam_bench.models.friction'} <= modules
