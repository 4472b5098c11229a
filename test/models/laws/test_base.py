"""A force law compiled by numba against the law as written (``laws.base.law_function``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pam_bench.models import jit
from pam_bench.models.law_muscle import LawMuscle
from pam_bench.models.laws.base import ForceLaw, law_function
from pam_bench.models.laws.zoo import FORCE_LAWS

RNG = np.random.default_rng(7)
P = RNG.uniform(0.0, 8.0e5, 200)
X = RNG.uniform(-0.01, 0.12, 200)


@pytest.mark.parametrize('law', FORCE_LAWS, ids=lambda law: law.name)
def test_every_law_of_the_zoo_compiles_and_gives_its_own_forces(law: ForceLaw) -> None:
    fast, why = law_function(law)
    assert why == '', why
    for theta in (np.array(law.start), 0.5 * (np.array(law.start) + np.clip(
            np.array(law.upper), None, 10 * np.abs(np.array(law.start)) + 1.0))):
        want = law.law(theta, P.copy(), X.copy(), 0.35)
        np.testing.assert_allclose(fast(theta, P.copy(), X.copy(), 0.35), want, rtol=1e-9,
                                   atol=1e-9)


def _uncompilable(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    p = np.asarray(p, float)           # a builtin type as dtype: numba cannot type it
    return th[0] * p * (1.0 - x / l0)


def test_a_law_numba_cannot_type_runs_as_written_and_says_why() -> None:
    law = ForceLaw('dict_law', 'a test', ('gain_m2',), (1e-3,), (1e-5,), (1e-1,),
                   _uncompilable)
    fn, why = law_function(law)
    assert fn is _uncompilable and why.startswith('numba cannot compile it:'), why
    muscle = LawMuscle(law, law.settings())
    assert muscle.interpreted_why == why
    assert muscle.backbone(3.0e5, 0.0) == pytest.approx(300.0)


def test_the_reference_core_runs_laws_as_written(monkeypatch: pytest.MonkeyPatch) -> None:
    def doubled(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
        return th[0] * p
    law = ForceLaw('plain', 'a test', ('gain_m2',), (1e-3,), (1e-5,), (1e-1,), doubled)
    jit.use('python')
    fn, why = law_function(law)
    assert fn is doubled and 'PAM_BENCH_CORE=python' in why


@pytest.mark.parametrize('law', [law for law in FORCE_LAWS if law.name in (
    'tondu_lopez', 'chou_hannaford', 'kang', 'al_ibadi')], ids=lambda law: law.name)
def test_a_law_compiled_whole_follows_the_reference(law: ForceLaw) -> None:
    """A protocol on the twin with 3 s exchanges (each one compiled call: ``law_kernel``)
    against the reference core (the law and the loop as written): the readings agree to
    1e-6 N and 1e-9 m (the compiled law's last bits may differ; the loop's operations are the
    reference's)."""
    from pam_bench.models.muscle import MuscleParams
    from pam_bench.twin.protocol_run import run_protocol
    muscle = dataclasses.replace(MuscleParams(), kind='law', law=law.name)

    def readings(core: str) -> tuple[np.ndarray, np.ndarray]:
        jit.use(core)
        run = run_protocol('isometric_quick', 3.0, muscle=muscle)
        return (np.array([p.measurement.force_n for p in run.points]),
                np.array([p.measurement.contraction_m for p in run.points]))
    fast, plain = readings('compiled'), readings('python')
    np.testing.assert_allclose(fast[0], plain[0], rtol=0.0, atol=1e-6)
    np.testing.assert_allclose(fast[1], plain[1], rtol=0.0, atol=1e-9)
