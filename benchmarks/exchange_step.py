"""Study ``exchange_step``: settled readings at coarse and adaptive exchange steps and
sub-steps against 1 ms exchanges on 1 ms sub-steps, per protocol kind (the numpy twin with the
sequencer's exchange steps)."""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import pct, table
from pam_bench.verify.reference_check import FULL_SCALE_N, series_readings

__all__ = ['STUDY', 'exchange_step_error', 'SCENE_STEPS', 'EXCHANGE_ROWS']

# (exchange step s, sub-step s) of the rows; the first is the characterisation scenes' own
SCENE_STEPS = (3.0, 0.005)
EXCHANGE_ROWS = [SCENE_STEPS, (3.0, 0.001), (3.0, 0.01), (0.1, 0.005), (0.01, 0.005)]


def exchange_step_error(quick: bool) -> list[dict[str, Any]]:
    """Error of settled readings against 1 ms exchanges on 1 ms sub-steps, per protocol kind,
    exchange step and sub-step (numpy twin: the sequencer's exchange steps and requests)."""
    du = 0.5 if quick else 0.1
    volts = list(np.round(np.arange(0.0, 6.0 + 1e-9, du), 9))
    volts = volts + volts[::-1]
    dF = 100.0 if quick else 10.0
    forces = list(np.arange(50.0, 950.0 + 1e-9, dF))
    forces = forces + forces[::-1]
    cases = [('isometric', 0.0, volts), ('isometric', 0.04, volts), ('isotonic', 500.0, volts),
             ('isotonic', 50.0, volts), ('isobaric', 4.0, forces)]
    if quick:                                   # one case of each protocol kind
        cases = [cases[0], cases[2], cases[4]]
    rows = []
    for kind, value, swept in cases:
        ref, _, wall_ref = series_readings(kind, value, swept, 0.001, 0.001)
        for h, sub in EXCHANGE_ROWS[:3] if quick else EXCHANGE_ROWS:
            out, spr, wall = series_readings(kind, value, swept, h, sub)
            err = np.abs(out - ref)
            unit = 'N' if kind == 'isometric' else 'mm'
            scale = 1.0 if kind == 'isometric' else 1e3
            rows.append({'protocol': kind, 'held': value, 'exchange_step_s': h,
                         'sub_step_s': sub, 'exchanges_per_reading': spr,
                         'max_error': float(err.max() * scale), 'unit': unit,
                         'max_error_pct_fs': (float(err.max() / FULL_SCALE_N * 100)
                                              if kind == 'isometric' else None),
                         'wall_s': wall, 'wall_s_1ms': wall_ref})
    return rows


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    return table(['protocol', 'held', 'exchange step', 'sub-step', 'exchanges per reading',
                  'max error', '% FS', 'wall s (reference wall s)'],
                 [(row['protocol'], f"{row['held']:g}", f"{row['exchange_step_s']:g} s",
                   f"{1e3 * row['sub_step_s']:g} ms", f"{row['exchanges_per_reading']:.1f}",
                   f"{row['max_error']:.3f} {row['unit']}", pct(row['max_error_pct_fs']),
                   f"{row['wall_s']:.2f} ({row['wall_s_1ms']:.1f})")
                  for row in r['exchange_step']])


STUDY = Study('exchange_step', 'readings at coarse exchange steps against 1 ms, per protocol',
              lambda quick, out, scenes: {'exchange_step': exchange_step_error(quick)},
              (('exchange_step', section),))
"""Exchange step and sub-step against error (bench.json ``exchange_step``)."""
