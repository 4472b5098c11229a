"""Study ``settle``: settled sub-steps (``models.coupling.SettleParams``) at a range of
tolerances: the twin campaign's speed and held share, its readings against the same run with
every sub-step solved, and series of readings against 1 ms exchanges on 1 ms sub-steps."""

from __future__ import annotations

import dataclasses
import pathlib
import time
from typing import Any

import numpy as np

from benchmarks.exchange_step import SCENE_STEPS
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.models.coupling import SETTLE_OFF, SettleParams

__all__ = ['STUDY', 'FACTORS', 'tolerances', 'settle_study']

FACTORS = (0.0, 0.3, 1.0, 3.0, 10.0, 100.0)
"""Tolerances as multiples of the default (0: every sub-step solved)."""


def tolerances(factor: float) -> SettleParams:
    """The default tolerances times ``factor`` (0: off)."""
    if factor <= 0.0:
        return SETTLE_OFF
    d = SettleParams()
    return dataclasses.replace(d, force_n=d.force_n * factor,
                               contraction_m=min(d.contraction_m * factor, 1e-2),
                               pressure_pa=d.pressure_pa * factor)


def _campaign(scene_name: str, factor: float) -> dict[str, Any]:
    """The twin of a scene with the settle tolerances times ``factor``: wall time, sub-steps,
    held sub-steps and its readings."""
    from pam_bench.config.scene import load_scene
    from pam_bench.twin.protocol_run import run_scene
    scene = load_scene(scene_name)
    for f in dataclasses.fields(SettleParams):
        scene.set(f'muscle_1.settle.{f.name}', getattr(tolerances(factor), f.name))
    t0 = time.perf_counter()
    run = run_scene(scene)
    wall = time.perf_counter() - t0
    return {'factor': factor, 'wall_s': wall, 'exchanges': run.exchanges,
            'substeps': run.substeps, 'held': run.held, 'exit_code': run.exit_code,
            'force_n': [p.measurement.force_n for p in run.points],
            'contraction_m': [p.measurement.contraction_m for p in run.points]}


def _series(quick: bool) -> list[dict[str, Any]]:
    """Series of readings at the scenes' steps with each tolerance, against 1 ms / 1 ms."""
    from pam_bench.verify.reference_check import series_readings
    du = 0.5 if quick else 0.1
    volts = list(np.round(np.arange(0.0, 6.0 + 1e-9, du), 9))
    volts = volts + volts[::-1]
    forces = list(np.arange(50.0, 950.0 + 1e-9, 100.0 if quick else 10.0))
    forces = forces + forces[::-1]
    cases = [('isometric', 0.04, volts), ('isotonic', 50.0, volts),
             ('isobaric', 4.0, forces)]
    rows = []
    for kind, value, swept in cases:
        ref, _, _ = series_readings(kind, value, swept, 0.001, 0.001)
        for factor in FACTORS:
            out, _, wall = series_readings(kind, value, swept, *SCENE_STEPS,
                                           settle=tolerances(factor))
            scale = 1.0 if kind == 'isometric' else 1e3
            rows.append({'protocol': kind, 'held': value, 'factor': factor,
                         'unit': 'N' if kind == 'isometric' else 'mm', 'wall_s': wall,
                         'max_error': float(np.abs(out - ref).max() * scale)})
    return rows


def settle_study(quick: bool) -> dict[str, Any]:
    """Both parts (module docstring); the campaign part on ``campaign_quick`` when quick."""
    from pam_bench.models import jit
    jit.warm_up()                  # numba's load is not the first row's
    scene = 'campaign_quick' if quick else 'campaign'
    runs = [_campaign(scene, f) for f in FACTORS]
    base = runs[0]
    f0, x0 = np.array(base['force_n']), np.array(base['contraction_m'])
    rows = []
    for r in runs:
        f, x = np.array(r.pop('force_n')), np.array(r.pop('contraction_m'))
        same = len(f) == len(f0)
        rows.append({**r, 'readings': len(f),
                     'max_force_diff_n': float(np.abs(f - f0).max()) if same else None,
                     'max_contraction_diff_mm': (float(1e3 * np.abs(x - x0).max()) if same
                                                 else None)})
    return {'scene': scene, 'campaign': rows, 'series': _series(quick),
            'default': dataclasses.asdict(SettleParams())}


def _num(v: float | None, fmt: str) -> str:
    return '' if v is None else format(v, fmt)


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    s = r['settle']
    d = s['default']
    head = [f"Default tolerances (x 1): force {d['force_n']:g} N, contraction "
            f"{1e6 * d['contraction_m']:g} um, pressure {d['pressure_pa']:g} Pa "
            '(`muscle_N.settle`). Twin of `' + s['scene'] + '`, readings against the same '
            'run with every sub-step solved (x 0):', '']
    camp = table(['tolerance', 'wall s', 'exchanges', 'sub-steps', 'held', 'max force diff',
                  'max contraction diff'],
                 [('off' if c['factor'] == 0 else f"x {c['factor']:g}", f"{c['wall_s']:.2f}",
                   c['exchanges'], c['substeps'], f"{100 * c['held'] / c['substeps']:.1f} %",
                   _num(c['max_force_diff_n'], '.3f') + ' N',
                   _num(c['max_contraction_diff_mm'], '.4f') + ' mm')
                  for c in s['campaign']])
    ser = table(['protocol', 'held', 'tolerance', 'max error against 1 ms / 1 ms', 'wall s'],
                [(row['protocol'], f"{row['held']:g}",
                  'off' if row['factor'] == 0 else f"x {row['factor']:g}",
                  f"{row['max_error']:.3f} {row['unit']}", f"{row['wall_s']:.2f}")
                 for row in s['series']])
    return head + camp + ['', "Series of readings at the scenes' steps (3 s exchanges, 5 ms "
                          'sub-steps) against 1 ms exchanges on 1 ms sub-steps:', ''] + ser


def results(r: dict[str, Any]) -> list[Row]:
    s = r.get('settle')
    if not s:
        return []
    by = {c['factor']: c for c in s['campaign']}
    off, on = by.get(0.0), by.get(1.0)
    if not (off and on):
        return []
    worst = {u: max((row['max_error'] for row in s['series']
                     if row['factor'] == 1.0 and row['unit'] == u), default=0.0)
             for u in ('N', 'mm')}
    return [(f"twin `{s['scene']}` with settled sub-steps held (default tolerances)", '-',
             f"{on['wall_s']:.2f} s against {off['wall_s']:.2f} s, "
             f"{100 * on['held'] / on['substeps']:.0f} % of sub-steps held",
             commit_of(r, 'settle')),
            ('readings with held sub-steps against 1 ms / 1 ms (series)',
             '<= 4 N and 0.42 mm', f"{worst['N']:.3f} N, {worst['mm']:.3f} mm",
             commit_of(r, 'settle'))]


STUDY = Study('settle', 'settled sub-steps held: speed against error at each tolerance',
              lambda quick, out, scenes: {'settle': settle_study(quick)},
              (('settle', section),), results)
"""Settled sub-steps: speed against error (bench.json ``settle``)."""
