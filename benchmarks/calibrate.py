"""Study ``calibrate``: the bag calibration's round trip on the numpy twin.

Parameter sets are drawn at random (seeded) within +-15 % of the defaults for the muscle's
gain, smallest gain, exponent, contact pressure and band, bladder and lock-up stiffnesses and
the valve's natural frequency and damping, and one set per drawn parameter puts that parameter
at an end of its fit interval (``FREE_BAGS``: the declared range, narrowed only for the
reasons ``BOUND_REASONS`` states), the lower end for every other parameter, the rest at their
defaults (``edge_parameters``); campaign_quick runs on the time-stepped numpy twin
(``twin.protocol_run``, noise-free load cell) with each; ``fit.calibrate_bags`` fits
``FREE_BAGS`` from the bench's defaults to its readings and step records. Reported per set:
each parameter's recovery error, whether the fit could identify it (not flagged), the RMS of
the readings before and after, the fit time.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.fit.calibrate_bags import FREE_BAGS, calibrate_bags, observations_from_twin
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.protocol_run import run_protocol

__all__ = ['STUDY', 'DRAWN', 'draw_parameters', 'edge_parameters', 'invalid', 'recovery_errors',
           'measure_round_trips', 'calibrate_section', 'calibrate_results']

DRAWN = ('gain_n_per_pa', 'gain_min_n_per_pa', 'gain_exponent', 'threshold_pressure_pa',
         'threshold_width_pa', 'bladder_stiffness_n_per_m', 'stretch_stiffness_n_per_m',
         'natural_frequency_rad_s', 'damping_ratio')
TOLERANCE = 0.05


def draw_parameters(rng: np.random.Generator) -> tuple[ValveParams, MuscleParams]:
    """A valve and muscle with ``DRAWN`` uniform within +-15 % of the defaults (clipped to
    the fit's bounds); a draw the muscle model refuses (``invalid``) is drawn again."""
    while True:
        m, v = MuscleParams(), ValveParams()
        mv: dict[str, Any] = {}
        vv: dict[str, Any] = {}
        for model, name, lo, hi in FREE_BAGS:
            if name not in DRAWN:
                continue
            base = getattr(v if model == 'valve' else m, name)
            value = float(np.clip(base * rng.uniform(0.85, 1.15), lo, hi))
            (vv if model == 'valve' else mv)[name] = value
        valve, muscle = dataclasses.replace(v, **vv), dataclasses.replace(m, **mv)
        if not invalid(valve, muscle):
            return valve, muscle


def invalid(valve: ValveParams, muscle: MuscleParams) -> str:
    """Why the models refuse these parameters ('' when they take them), e.g. a gain rise past
    x_m that the bladder's stiffness no longer holds."""
    from pam_bench.models.errors import ModelError
    from pam_bench.models.muscle import MuscleModel
    from pam_bench.models.valve import ValveModel
    try:
        MuscleModel(muscle)
        ValveModel(valve)
    except (ModelError, ValueError) as exc:
        return str(exc)
    return ''


def edge_parameters(k: int) -> tuple[ValveParams, MuscleParams, str]:
    """The ``DRAWN`` parameter k at an end of its fit interval (the lower end for even k),
    everything else at its default; returns (valve, muscle, 'name at lower|upper end')."""
    name = DRAWN[k % len(DRAWN)]
    model, _, lo, hi = next(row for row in FREE_BAGS if row[1] == name)
    end = 'lower' if k % 2 == 0 else 'upper'
    value = lo if end == 'lower' else hi
    v, m = ValveParams(), MuscleParams()
    change: dict[str, Any] = {name: value}
    if model == 'valve':
        v = dataclasses.replace(v, **change)
    else:
        m = dataclasses.replace(m, **change)
    return v, m, f'{name} at its {end} end ({value:g})'


def recovery_errors(values: dict[str, float], valve: ValveParams, muscle: MuscleParams
                    ) -> dict[str, float | None]:
    """Relative error of each fitted ``FREE_BAGS`` value against the drawn ``valve`` and
    ``muscle`` (the friction scale against 1); None where the true value is 0."""
    errors: dict[str, float | None] = {}
    for model, name, _, _ in FREE_BAGS:
        true = 1.0 if name == 'friction_stiffness_scale' else \
            getattr(valve if model == 'valve' else muscle, name)
        errors[name] = (values[name] - true) / true if true else None
    return errors


def measure_round_trips(quick: bool, sets: int | None = None,
                        edges: int | None = None) -> dict[str, Any]:
    """Run the round trip (module docstring) for ``sets`` drawn sets (1 quick, 5 full) and
    ``edges`` sets with one parameter at an end (none quick, one per drawn parameter full)."""
    rng = np.random.default_rng(2026)
    cases: list[tuple[ValveParams, MuscleParams, str]] = [
        (*draw_parameters(rng), 'drawn') for _ in range(sets or (1 if quick else 5))]
    n_edges = edges if edges is not None else (0 if quick else len(DRAWN))
    cases += [edge_parameters(k) for k in range(n_edges)]
    rows: list[dict[str, Any]] = []
    edge_rows: list[dict[str, Any]] = []
    for k, (valve, muscle, what) in enumerate(cases):
        print(f'  round trip {k + 1} ({what}) ...', flush=True)
        refused = invalid(valve, muscle)
        if refused:                      # not a muscle the model takes: said, not run
            edge_rows.append({'set': what, 'refused': refused})
            continue
        run = run_protocol('campaign_quick', 3.0, valve=valve, muscle=muscle,
                           load_cell=LoadCellParams(noise=False))
        res = calibrate_bags(observations_from_twin(run.points, run.records))
        row = {'set': what, 'errors': recovery_errors(res['values'], valve, muscle),
               'flags': res['flags'], 'at_bound': res.get('at_bound', []),
               'fit_s': res['fit_s'], 'evaluations': res['evaluations'],
               'rms_before': res['rms_before'], 'rms_after': res['rms_after']}
        (rows if what == 'drawn' else edge_rows).append(row)
    return {'sets': rows, 'edges': edge_rows, 'tolerance': TOLERANCE}


def calibrate_section(r: dict[str, Any]) -> list[str]:
    """Recovery per parameter over the sets, and the readings after the fit."""
    c = r['calibrate']
    sets = c['sets']
    names = list(sets[0]['errors'])
    lines = table(['parameter', 'drawn', 'identified in', 'largest error when identified',
                   'within 5 %'],
                  [(n, 'yes' if n in DRAWN else 'no (default)',
                    f"{sum(1 for s in sets if n not in s['flags'])} of {len(sets)}",
                    _largest(sets, n), _within(sets, n, c['tolerance']))
                   for n in names])
    lines += ['', table_note(sets)]
    edges = c.get('edges', [])
    if edges:
        lines += ['', 'One parameter at an end of its fit interval, the rest at the defaults: '
                  "what the fit says of it (an error within 5 %, 'at its bound', or flagged as "
                  'not fixed by the recordings):', '']
        lines += table(['set', 'identified value error', 'reported as', 'other parameters '
                        'outside 5 %', 'readings RMS after'],
                       [_edge_row(e, c['tolerance']) for e in edges])
    return lines


def _edge_row(e: dict[str, Any], tol: float) -> Row:
    name = e['set'].split(' ')[0]
    if 'refused' in e:
        return (e['set'], '-', f"not a valid muscle: {e['refused']}", '-', '-')
    err = e['errors'].get(name)
    said = ('at its bound' if name in e.get('at_bound', []) else
            'not fixed' if name in e['flags'] else 'identified')
    others = [n for n, v in e['errors'].items() if n != name and n not in e['flags']
              and v is not None and abs(v) > tol]
    rms = ', '.join(f'{k} {v:.2f}' for k, v in e['rms_after'].items())
    return (e['set'], '-' if err is None else f'{100 * err:+.2f} %', said,
            ', '.join(others) or 'none', rms)


def _identified(sets: list[dict[str, Any]], name: str) -> list[float]:
    return [abs(s['errors'][name]) for s in sets
            if name not in s['flags'] and s['errors'][name] is not None]


def _largest(sets: list[dict[str, Any]], name: str) -> str:
    errs = _identified(sets, name)
    return f'{max(errs) * 100:.2f} %' if errs else '-'


def _within(sets: list[dict[str, Any]], name: str, tol: float) -> str:
    errs = _identified(sets, name)
    return '-' if not errs else 'yes' if max(errs) <= tol else 'NO'


def table_note(sets: list[dict[str, Any]]) -> str:
    """The readings' RMS after the fit and the fit times, one sentence."""
    worst: dict[str, float] = {}
    for s in sets:
        for k, v in s['rms_after'].items():
            worst[k] = max(worst.get(k, 0.0), v)
    parts = ', '.join(f"{k} {v:.2f} {'mm' if k in ('isotonic', 'isobaric') else 'N'}"
                      for k, v in worst.items())
    fit = ', '.join(f"{s['fit_s']:.0f} s" for s in sets)
    return (f'Largest RMS of the readings after the fit, over the sets: {parts} (goal 20 N = '
            f'1 % FS and 0.5 mm). Fit times: {fit}.')


def calibrate_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result row: identifiable parameters recovered within 5 %."""
    c = r.get('calibrate')
    if not c:
        return []
    sets = c['sets']
    ok = sum(1 for s in sets if all(abs(e) <= c['tolerance'] for n, e in s['errors'].items()
                                    if n not in s['flags'] and e is not None))
    return [('bag calibration round trip (numpy twin, campaign_quick): sets with every '
             'identified parameter within 5 %', f'{len(sets)} of {len(sets)}',
             f'{ok} of {len(sets)}', commit)]


STUDY = Study(
    'calibrate', 'pam-bench calibrate on drawn muscles (the numpy twin), recovery per parameter',
    lambda quick, out, scenes: {'calibrate': measure_round_trips(quick)},
    (('calibrate', lambda r, root: calibrate_section(r)),),
    lambda r: calibrate_results(r, commit_of(r, 'calibrate')))
"""The calibration round trip (bench.json ``calibrate``)."""
