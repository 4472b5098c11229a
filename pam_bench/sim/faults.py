"""Injected faults: what a scene's ``faults`` list does to a device, and when.

A fault has a kind, a target node, a start ``at_s`` (s from the start of the run: the
protocol's start, as the first protocol status past idle states it, or the first servo state
the target receives) and a ``duration_s``; ``value`` is the
kind's size. Kinds:

* ``sensor_dropout`` (load cell, encoder, valve pressure): the measured topic stops;
* ``sensor_drift``: the measured value drifts by ``value`` per second (N/s, rad/s, Pa/s);
* ``sensor_noise_burst``: Gaussian noise of standard deviation ``value`` on the value;
* ``message_loss``: each measured message is dropped with probability ``value``;
* ``valve_stuck`` (valve): commands are ignored, the last voltage stays;
* ``node_kill`` (any node): the runner kills the node's process (SIGKILL) at ``at_s``;
* on the buses (``run --wallclock --buses``, target the driver whose bus it hits; times from
  the protocol's start, with ``emulate --buses`` from the start of the buses):
  ``modbus_down`` (daq_modbus: the DAQ's server goes away for ``duration_s``),
  ``register_out_of_range`` (daq_modbus: the load cell's register holds ``value`` N, outside
  the map's range), ``can_emcy`` (servo_canopen: the drive faults and sends an EMCY),
  ``can_silent`` (servo_canopen: the drive stops its heartbeat and PDOs for ``duration_s``).
  A driver whose device is down publishes nothing: a suspender on the input it carries
  (``stale_s``) suspends the run, ``drive`` for the CAN drive.

Faults run on a wall clock (a lock-step participant that drops a message stalls the run by
design). Parsed strictly: an unknown key, kind or target is an error naming it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from pam_bench.vocabulary.errors import ParameterError, shorten
from pam_bench.vocabulary.params import check_known

__all__ = ['Fault', 'KINDS', 'SENSOR_KINDS', 'BUS_KINDS', 'parse_faults', 'sensor_value']

SENSOR_KINDS = ('sensor_dropout', 'sensor_drift', 'sensor_noise_burst', 'message_loss')
BUS_KINDS = {'modbus_down': 'daq_modbus', 'register_out_of_range': 'daq_modbus',
             'can_emcy': 'servo_canopen', 'can_silent': 'servo_canopen'}
"""Bus fault kind -> the driver whose bus it hits."""
KINDS = (*SENSOR_KINDS, 'valve_stuck', 'node_kill', *BUS_KINDS)
_SENSORS = ('load_cell_1', 'load_cell_2', 'encoder', 'valve_1', 'valve_2')


@dataclasses.dataclass(frozen=True)
class Fault:
    """One injected fault (module docstring); times in s."""

    kind: str
    target: str
    at_s: float
    duration_s: float = 1.0
    value: float = 0.0

    def active(self, t_s: float) -> bool:
        """Whether the fault acts at ``t_s`` (s from the start of the run)."""
        return self.at_s <= t_s < self.at_s + self.duration_s


def parse_faults(data: Any, nodes: list[str]) -> list[Fault]:
    """Faults from a scene's parsed ``faults`` list.

    Raises:
        ParameterError: not a list of mappings, an unknown key or kind, a target not in
            ``nodes`` or of the wrong sort, a negative time, a probability out of [0, 1].
    """
    if data in (None, []):
        return []
    if not isinstance(data, list):
        raise ParameterError(f'faults: a list, got {shorten(data)}')
    out = []
    keys = [f.name for f in dataclasses.fields(Fault)]
    for i, item in enumerate(data):
        where = f'faults[{i}]'
        if not isinstance(item, Mapping):
            raise ParameterError(f'{where}: a mapping, got {item!r}')
        check_known(item, keys, where)
        kind, target = item.get('kind'), item.get('target')
        if kind not in KINDS:
            raise ParameterError(f'{where}.kind: one of {", ".join(KINDS)}, got {kind!r}')
        if kind in BUS_KINDS:
            if target != BUS_KINDS[kind]:
                raise ParameterError(f'{where}: {kind} hits the bus of {BUS_KINDS[kind]}, '
                                     f'not {target!r}')
        elif target not in nodes:
            raise ParameterError(f'{where}.target: a node of the scene, got {target!r}')
        if kind in SENSOR_KINDS and target not in _SENSORS:
            raise ParameterError(f'{where}: {kind} needs a sensor (load cell, encoder, valve '
                                 f'pressure), not {target!r}')
        if kind == 'valve_stuck' and not str(target).startswith('valve_'):
            raise ParameterError(f'{where}: valve_stuck needs a valve, not {target!r}')
        try:
            f = Fault(kind, target, float(item.get('at_s', math.nan)),
                      float(item.get('duration_s', 1.0)), float(item.get('value', 0.0)))
        except (TypeError, ValueError):
            raise ParameterError(f'{where}: numbers expected, got {item!r}') from None
        if not (f.at_s >= 0.0 and f.duration_s >= 0.0):
            raise ParameterError(f'{where}: at_s and duration_s must be >= 0 s')
        if kind == 'message_loss' and not 0.0 <= f.value <= 1.0:
            raise ParameterError(f'{where}: message_loss value is a probability in [0, 1]')
        out.append(f)
    return out


def sensor_value(faults: list[Fault], t_s: float, value: float, gauss: float,
                 uniform: float) -> float | None:
    """The value a faulty sensor reports at ``t_s`` (None: nothing is published).

    Args:
        faults: the target's faults.
        t_s: s from the start of the run.
        value: the true reading.
        gauss: a standard normal draw (noise bursts).
        uniform: a uniform draw in [0, 1) (message loss).
    """
    for f in faults:
        if not f.active(t_s):
            continue
        if f.kind == 'sensor_dropout':
            return None
        if f.kind == 'message_loss' and uniform < f.value:
            return None
        if f.kind == 'sensor_drift':
            value += f.value * (t_s - f.at_s)
        elif f.kind == 'sensor_noise_burst':
            value += f.value * gauss
    return value
