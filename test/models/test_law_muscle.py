"""A force law of the zoo as the bench's muscle (``models.law_muscle``)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pam_bench.models.bench_muscle import make_muscle
from pam_bench.models.law_muscle import LawMuscle
from pam_bench.models.laws.zoo import FORCE_LAWS, all_laws, force_law
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import flat_infos


@pytest.mark.parametrize('p, x', [(1e5, 0.0), (3e5, 0.02), (5e5, 0.05)])
def test_without_friction_the_force_is_the_laws(p: float, x: float) -> None:
    law = force_law('chou_hannaford')
    muscle = LawMuscle(law, law.settings(), dataclasses.replace(MuscleParams(),
                                                                hysteresis=False))
    f, k, ff, _ = muscle.trial(p, x)
    want = float(law.law(np.array(law.start), np.asarray(p), np.asarray(x), 0.35))
    np.testing.assert_allclose(f, max(want, 0.0), rtol=1e-12)
    assert ff == 0.0
    # -dF/dx of 001 Eq. 3: (pi D0^2 p / 4) / sin^2 t0 * 6 (1 - k) cos^2 t0 / l0
    d0, t0 = law.start
    dfdx = math.pi * d0 ** 2 * p / 4 / math.sin(t0) ** 2 * 6 * (1 - x / 0.35) * \
        math.cos(t0) ** 2 / 0.35
    np.testing.assert_allclose(k, dfdx, rtol=1e-6)


def test_the_volume_is_the_mckibben_braids() -> None:
    law = force_law('kang')
    m = LawMuscle(law, law.settings())
    np.testing.assert_allclose(m.volume(0.03), MuscleModel().volume(0.03), rtol=1e-15)


def test_a_scene_selects_a_law_by_name() -> None:
    muscle = make_muscle(dataclasses.replace(MuscleParams(), kind='law', law='tondu_lopez'))
    assert isinstance(muscle, LawMuscle) and muscle.law.name == 'tondu_lopez'
    with pytest.raises(ParameterError, match="did you mean 'tondu_lopez'"):
        make_muscle(dataclasses.replace(MuscleParams(), kind='law', law='tondu_lopz'))


@pytest.mark.parametrize('law', FORCE_LAWS, ids=lambda law: law.name)
def test_every_law_has_settings_with_its_start_and_bounds(law) -> None:
    infos = flat_infos(law.settings)
    assert [i.name for i in infos] == list(law.params)
    assert [i.default for i in infos] == list(law.start)
    np.testing.assert_array_equal(law.theta(law.settings()), law.start)
    assert law in all_laws()


@pytest.mark.parametrize('exchange_s, sub_s, core', [
    (0.01, 0.005, 'interpreted'),      # the demo: 2 sub-steps an exchange
    (0.001, 0.005, 'interpreted'),     # a servo scene: one
    (0.155, 0.005, 'interpreted'),     # 31
    (0.16, 0.005, 'compiled'),         # 32 (jit.LOAD_AT)
    (3.0, 0.005, 'compiled'),          # a campaign's exchanges
])
def test_a_scene_runs_its_law_compiled_when_exchanges_are_long(exchange_s: float, sub_s: float,
                                                                core: str) -> None:
    from pam_bench.models.law_muscle import law_core_for
    assert law_core_for(exchange_s, sub_s) == core


def test_a_law_asked_to_run_interpreted_runs_as_written() -> None:
    law = force_law('chou_hannaford')
    plain = LawMuscle(law, law.settings(), dataclasses.replace(MuscleParams(), kind='law',
                                                               law_core='interpreted'))
    fast = LawMuscle(law, law.settings(), dataclasses.replace(MuscleParams(), kind='law',
                                                              law_core='compiled'))
    assert plain._law is law.law and plain.kernel() is None
    assert plain.interpreted_why == 'muscle.law_core is interpreted'
    assert fast.interpreted_why == '' and fast._law is not law.law
    for p, x in [(1e5, 0.0), (3e5, 0.02), (5e5, 0.05)]:
        np.testing.assert_allclose(plain.backbone_and_stiffness(p, x),
                                   fast.backbone_and_stiffness(p, x), rtol=1e-9)
