"""What a protocol entry may hold: one settings dataclass per kind, every key typed and bounded.

An entry of config/protocols.yaml, and a scene's or a goal's ``protocol_overrides`` over it, is
checked against its kind's dataclass (``vocabulary.params.field``: type, unit, range), so a
wrongly typed, non-finite, negative or zero value (a zero ramp rate) is one ``ParameterError``
naming the key before anything starts. Grids are ``[from, to, step]`` (SI: m, N, V): the step
is non-zero and leads from ``from`` to ``to``; a protocol holds at most ``MAX_READINGS``
readings (004's whole campaign holds 7078).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from pam_bench.protocol.window import READING_WINDOW_S
from pam_bench.vocabulary.errors import ParameterError, shorten
from pam_bench.vocabulary.params import check_known, field, from_mapping, hint, section

__all__ = ['SPECS', 'StepSpec', 'check_protocol', 'grid_count', 'MAX_READINGS', 'KINDS']

MAX_READINGS = 1_000_000
"""Readings a protocol may hold (a bound on memory and on the schedule's build time)."""
_VOLTS = 10.0       # the valve's command range, V
_FORCE = 1.0e4      # N, ten times the load cell's range
_METRES = 1.0       # m


@dataclasses.dataclass
class _Common:
    """Keys every kind takes."""

    kind: str = field('isometric', '-', 'what the protocol does', choices=(
        'ramp', 'isometric', 'isotonic', 'isobaric', 'step_response', 'campaign'))
    dwell_s: float = field(3.0, 's', 'wait at each set value before its reading', 1e-3, 3600.0)
    settle_s: float = field(3.0, 's', 'wait before the first reading (default: dwell_s)', 0.0,
                            3600.0)
    reading_window_s: float = field(READING_WINDOW_S, 's', 'a reading averages the samples '
                                    'of this last part of its dwell', 0.0, 3600.0)


@dataclasses.dataclass
class RampSpec(_Common):
    """Hold a load, ramp the voltage through breakpoints, read at a fixed period."""

    load_mode: str = field('position', '-', 'what the loading servo holds',
                           choices=('off', 'force', 'position'))
    load_value: float = field(0.0, 'N or m', 'the held force or position', -_FORCE, _FORCE)
    voltage_v: list[float] = field([0.0, 6.0, 0.0], 'V', 'the ramp breakpoints', 0.0, _VOLTS)
    ramp_rate_v_per_s: float = field(1.0, 'V/s', 'ramp speed', 1e-4, 1e3)
    reading_every_s: float = field(0.5, 's', 'time between readings', 1e-3, 3600.0)


@dataclasses.dataclass
class IsometricSpec(_Common):
    """Series of held positions, the voltage swept up then down."""

    x_m: list[float] = field([0.0, 0.11, 0.005], 'm', 'held positions [from, to, step]',
                             -_METRES, _METRES)
    voltage_v: list[float] = field([0.0, 6.0, 0.1], 'V', 'swept voltage [from, to, step]',
                                   -_VOLTS, _VOLTS)


@dataclasses.dataclass
class IsotonicSpec(_Common):
    """Series of held forces, the voltage swept up then down."""

    force_n: list[float] = field([50.0, 950.0, 50.0], 'N', 'held forces [from, to, step]',
                                 -_FORCE, _FORCE)
    voltage_v: list[float] = field([0.0, 6.0, 0.1], 'V', 'swept voltage [from, to, step]',
                                   -_VOLTS, _VOLTS)


@dataclasses.dataclass
class IsobaricSpec(_Common):
    """Series of held voltages, the force swept up then down."""

    voltage_v: list[float] = field([0.0, 6.0, 1.0], 'V', 'held voltages [from, to, step]',
                                   -_VOLTS, _VOLTS)
    force_n: list[float] = field([50.0, 950.0, 10.0], 'N', 'swept force [from, to, step]',
                                 -_FORCE, _FORCE)


@dataclasses.dataclass
class StepSpec:
    """One direction of step responses: from ``u0_v``, ``n`` steps of ``step_v``."""

    u0_v: float = field(1.0, 'V', 'voltage held before each step', 0.0, _VOLTS)
    step_v: float = field(0.2, 'V', 'step size (n-th step: u0 + n step)', -_VOLTS, _VOLTS)
    n: int = field(20, '-', 'steps', 0, 10_000)


@dataclasses.dataclass
class StepResponseSpec(_Common):
    """Per held position, steps of the voltage with the force recorded after each."""

    x_m: list[float] = field([0.0, 0.08, 0.005], 'm', 'held positions [from, to, step]',
                             -_METRES, _METRES)
    up: StepSpec = section(StepSpec, 'the upward steps')
    down: StepSpec = section(StepSpec, 'the downward steps')
    record_s: float = field(1.0, 's', 'record length after each step', 1e-3, 600.0)
    sample_period_s: float = field(0.001, 's', 'record sample period', 1e-5, 1.0)


@dataclasses.dataclass
class CampaignSpec(_Common):
    """Other protocols of the table, one after the other."""

    protocols: list[str] = field([], '-', 'protocol names, in order', item=str)


SPECS: dict[str, type] = {'ramp': RampSpec, 'isometric': IsometricSpec,
                          'isotonic': IsotonicSpec, 'isobaric': IsobaricSpec,
                          'step_response': StepResponseSpec, 'campaign': CampaignSpec}
"""The dataclass of each protocol kind."""
KINDS = tuple(SPECS)
_GRIDS = {'isometric': ('x_m', 'voltage_v'), 'isotonic': ('force_n', 'voltage_v'),
          'isobaric': ('voltage_v', 'force_n'), 'step_response': ('x_m',)}


def grid_count(name: str, key: str, values: list[float]) -> int:
    """Points of the grid ``[from, to, step]``.

    Raises:
        ParameterError: not three numbers, a zero step, or a step leading away from ``to``.
    """
    if len(values) != 3:
        raise ParameterError(f'protocol {name!r}: {key} must be [from, to, step], got '
                             f'{shorten(values)}')
    start, stop, step = values
    if start == stop:
        return 1
    if step == 0.0 or (stop - start) / step < 0:
        raise ParameterError(f'protocol {name!r}: {key} step {step} does not lead from {start} '
                             f'to {stop}')
    count = (stop - start) / step
    if count > MAX_READINGS:
        raise ParameterError(f'protocol {name!r}: {key} has {count:.3g} points (at most '
                             f'{MAX_READINGS})')
    return int(round(count)) + 1


def check_protocol(name: str, cfg: Mapping[str, Any]) -> None:
    """Check a protocol entry: its kind, its keys (named, with the nearest known one), each
    value's type and range (its kind's dataclass), its grids and its number of readings.

    Raises:
        ParameterError: the first thing wrong, named.
    """
    kind = cfg.get('kind')
    if not isinstance(kind, str) or kind not in SPECS:
        raise ParameterError(f'protocol {name!r}: unknown kind {shorten(kind)} '
                             f'({hint(str(kind)[:80], SPECS)})')
    spec_cls = SPECS[kind]
    check_known(cfg, [f.name for f in dataclasses.fields(spec_cls)], f'protocol {name!r} ({kind})')
    try:
        spec: Any = from_mapping(spec_cls, cfg)
    except ParameterError as exc:
        raise ParameterError(f'protocol {name!r}: {exc}') from None
    if 'settle_s' not in cfg:
        spec.settle_s = spec.dwell_s
    if kind != 'campaign' and spec.reading_window_s > spec.dwell_s:
        raise ParameterError(f'protocol {name!r}: reading_window_s {spec.reading_window_s} '
                             f'must be in [0, dwell_s = {spec.dwell_s}]')
    total = 1
    for key in _GRIDS.get(kind, ()):
        if key in cfg:
            total *= grid_count(name, key, getattr(spec, key))
    if kind == 'step_response':
        total *= 2 * max(spec.up.n, spec.down.n)
    if kind == 'ramp':
        pts = spec.voltage_v
        if len(pts) < 2:
            raise ParameterError(f'protocol {name!r}: voltage_v needs at least two breakpoints')
        total = int(sum(abs(b - a) for a, b in zip(pts[:-1], pts[1:], strict=True))
                    / spec.ramp_rate_v_per_s / spec.reading_every_s) + len(pts)
    if total > MAX_READINGS or not math.isfinite(total):
        raise ParameterError(f'protocol {name!r}: about {total:.3g} readings (at most '
                             f'{MAX_READINGS})')
