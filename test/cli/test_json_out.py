"""``--json`` prints strict JSON (``cli.json_out``): what a parser other than Python's reads."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pam_bench.cli.json_out import dumps


def strict(text: str) -> object:
    """Parse as a strict (RFC 8259) parser does: NaN and Infinity are not JSON."""
    def refuse(constant: str) -> object:
        pytest.fail(f'{constant} in the JSON')
    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize(('value', 'expected'), [
    ({'stderr': math.nan, 'rise': [math.inf, -math.inf, 1.5]}, {'stderr': None,
                                                                'rise': [None, None, 1.5]}),
    ({'a': np.float64('nan'), 'b': np.float64(2.0), 'c': np.int64(3)}, {'a': None, 'b': 2.0,
                                                                        'c': 3}),
    ((1.0, 'x', None, True), [1.0, 'x', None, True]),
])
def test_non_finite_floats_are_null_and_the_rest_as_it_was(value: object,
                                                           expected: object) -> None:
    assert strict(dumps(value)) == expected
