"""Register maps: strict checking, raw <-> SI both ways, the shipped maps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.buses.errors import MapError
from pam_bench.buses.register_map import TYPES, load_register_map, parse_register_map

GOOD = {'signal': 'load_cell_1.force', 'register': 'input', 'address': 0, 'type': 'float32',
        'unit': 'N', 'low': -2000.0, 'high': 2000.0}


def _map(*channels: dict, **top: object) -> dict:
    return {'name': 'test', 'channels': list(channels), **top}


@pytest.mark.parametrize('data, words', [
    (_map({**GOOD, 'adress': 3}), "'adress'"),                         # misspelt key
    (_map(GOOD, word_ordr='big'), "'word_ordr'"),
    (_map({**GOOD, 'signal': 'load_cell_3.force'}), 'load_cell_3.force'),
    (_map({**GOOD, 'signal': 'valve_1.voltage', 'unit': 'V'}), 'holding'),   # output in IR
    (_map(GOOD, {**GOOD, 'address': 1, 'signal': 'encoder.angle', 'unit': 'rad'}),
     'share input register 1'),
    (_map(GOOD, {**GOOD, 'address': 4}), 'repeats signal load_cell_1.force'),
    (_map({**GOOD, 'low': 5.0, 'high': 5.0}), 'low must be below high'),
    (_map({**GOOD, 'scale': 0}), 'scale must not be 0'),
    (_map({**GOOD, 'type': 'float64'}), 'type must be one of'),
    (_map({**GOOD, 'unit': 'kN'}), "not 'kN'"),
    (_map({**GOOD, 'address': 70000}), 'address must be'),
    (_map({**GOOD, 'offset': float('nan')}), 'offset must be a finite number'),
    (_map(), 'channels must be a non-empty list'),
    (_map(GOOD, device_id=300), 'device_id'),
])
def test_a_bad_map_is_one_error_naming_what(data: dict, words: str) -> None:
    with pytest.raises(MapError, match=None) as info:
        parse_register_map(data, 'map.yaml')
    assert words in str(info.value) and '\n' not in str(info.value)


@pytest.mark.parametrize('kind', sorted(TYPES))
@pytest.mark.parametrize('order', ['big', 'little'])
def test_encode_then_decode_gives_the_value_back(kind: str, order: str) -> None:
    signed = kind.startswith(('int', 'float'))
    chan = {**GOOD, 'type': kind, 'scale': 0.25, 'offset': -1000.0 if not signed else 0.0}
    m = parse_register_map(_map(chan, word_order=order), 'map.yaml')
    c = m.channels[0]
    for value in (-1000.0 if not signed else -1999.5, -3.25, 0.0, 123.5, 1999.75):
        if not signed and value < -1000.0:
            continue
        words = m.encode(c, value)
        assert len(words) == c.count and all(0 <= w <= 0xFFFF for w in words)
        tol = 0.125 + 1e-9 if kind != 'float32' else 1e-3      # half a count of 0.25 N
        np.testing.assert_allclose(m.decode(c, words), value, atol=tol)


def test_a_value_out_of_range_is_refused_both_ways() -> None:
    m = parse_register_map(_map(GOOD), 'map.yaml')
    c = m.channels[0]
    for bad in (2000.5, -2500.0, math.inf, math.nan):
        with pytest.raises(ValueError):
            m.encode(c, bad)
    wide = parse_register_map(_map({**GOOD, 'low': -1e9, 'high': 1e9}), 'map.yaml')
    assert math.isnan(m.decode(c, wide.encode(wide.channels[0], 2500.0)))   # a flipped wire
    assert math.isnan(m.decode(c, [0x7FC0, 0]))                              # a float NaN


def test_the_shipped_maps() -> None:
    generic = load_register_map('daq_generic')
    assert [(b.register, b.address, b.count) for b in generic.blocks(False)] == \
        [('input', 0, 8)]                              # one read of every input
    assert [(b.address, b.count) for b in generic.blocks(True)] == [(0, 4)]
    t7 = load_register_map('labjack_t7')
    assert [(b.address, b.count) for b in t7.blocks(False)] == [(0, 4), (3000, 2)]
    c = t7.channel('valve_1.pressure')
    assert c is not None
    np.testing.assert_allclose(t7.decode(c, t7.encode(c, 3.0e5)), 3.0e5, rtol=1e-6)
    enc = t7.channel('encoder.angle')
    assert enc is not None and t7.decode(enc, t7.encode(enc, -1.0)) == pytest.approx(
        -1.0, abs=2 * math.pi / 65536)
