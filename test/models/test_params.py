"""Parameter sets: a bad value gets one clear message naming its key."""

from __future__ import annotations

import pytest

from pam_bench.models.muscle import MuscleParams
from pam_bench.models.valve import ValveParams
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import check_known, from_mapping


@pytest.mark.parametrize('values, key', [
    ({'gain_pa_per_v': 'x'}, 'valve.gain_pa_per_v'),
    ({'order': 3}, 'valve.order'),
    ({'damping_ratio': float('nan')}, 'valve.damping_ratio'),
    ({'typo_key': 1.0}, 'valve.typo_key'),
    ({'volume_scaling': 'yes'}, 'valve.volume_scaling'),
    ({0.0: None, 'zz_key': 1.0}, 'valve.0.0'),       # YAML 1.2 reads a key 0E0 as a float
    ({'': None, 1: 2}, "valve.'"),
])
def test_bad_values_name_the_key(values: dict, key: str) -> None:
    with pytest.raises(ParameterError, match=key.replace('.', r'\.')):
        from_mapping(ValveParams, values, prefix='valve.')


def test_lists_checked_elementwise() -> None:
    with pytest.raises(ParameterError, match='friction_break_force_n'):
        from_mapping(MuscleParams, {'friction_break_force_n': [1.0, -2.0, 1.0]})


def test_good_values_pass() -> None:
    p = from_mapping(ValveParams, {'order': 1, 'time_constant_s': 0.05})
    assert p.order == 1 and p.time_constant_s == 0.05


def test_keys_of_mixed_types_are_named_not_a_traceback() -> None:
    """A sweep or scene whose keys are a string and a number (``'': ..., 0E0: ...``): the
    first unknown key in the order of their texts, one ParameterError."""
    with pytest.raises(ParameterError, match=r"sweep: unknown key '0\.0'"):
        check_known({'': 1, 0.0: 2}, ['', 'scene'], 'sweep')
