"""Study ``straight_fibre``: 000's prototype through the nodes (both scenes), its figures
against 000 section 2.3, and the zoo's laws fitted to its readings."""

from __future__ import annotations

import pathlib
import time
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.analysis.extract import model_comparison
from pam_bench.bags.bagread import read_bags
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.verify.prototype import prototype_figures
from pam_bench.vocabulary.run import RunOptions

__all__ = ['STUDY', 'SCENES', 'measure_straight_fibre', 'straight_fibre_section',
           'straight_fibre_results']

SCENES = {3: 'straight_fibre_quick', 4: 'straight_fibre_4_quick'}


def measure_straight_fibre(out: pathlib.Path) -> dict[str, Any]:
    """Run both scenes, read the prototype's figures and fit the laws (3 segments)."""
    figures: list[dict[str, Any]] = []
    runs, laws = [], []
    for segments, name in SCENES.items():
        print(f'  {name} ...', flush=True)
        bag = out / name
        t0 = time.perf_counter()
        res = run_scene(load_scene(name), str(bag), RunOptions(quiet=True))
        runs.append({'scene': name, 'code': res.code, 'sim_s': res.sim_s,
                     'wall_s': time.perf_counter() - t0})
        points = read_bags([bag]).points
        figures += prototype_figures(points, segments)
        if segments == 3:
            laws = [{k: v for k, v in m.items() if not k.startswith('_')}
                    for m in model_comparison(points, nominal_length_m=0.25)]
    return {'runs': runs, 'figures': figures, 'laws': laws}


def straight_fibre_section(r: dict[str, Any]) -> list[str]:
    """The prototype table and the law table."""
    s = r['straight_fibre']

    def fmt(v: float, unit: str) -> str:
        return f'{v:.1f} N' if unit == 'N' else f'{v * 100:.1f} %'

    lines = table(['segments', 'figure', '000', 'bench', 'error', 'tolerance', 'within'],
                  [(f['segments'], f['figure'], fmt(f['paper'], f['unit']),
                    fmt(f['bench'], f['unit']),
                    f"{f['error'] * 100:+.1f} %" if f['relative']
                    else f"{f['error'] * 100:+.2f} points",
                    f"{f['tolerance'] * 100:g} %" if f['relative']
                    else f"{f['tolerance'] * 100:g} points", 'yes' if f['ok'] else 'NO')
                   for f in s['figures']])
    lines += ['', 'Runs: ' + '; '.join(f"{x['scene']} {x['sim_s']:.0f} s of bench time in "
                                        f"{x['wall_s']:.1f} s wall (exit {x['code']})"
                                        for x in s['runs']) + '.', '']
    lines += ['The zoo fitted to the 3-segment readings (isometric, isobaric and isotonic '
              'pooled; l0 = 250 mm):', '']
    lines += table(['law', 'seed', 'parameters', 'RMSE N', 'max error N', 'length RMSE mm',
                    'stiffness RMSE kN/m'],
                   [(m['model'], m['seed'], m['n_params'], f"{m['rmse_N']:.2f}",
                     f"{m['max_error_N']:.1f}", _opt(m.get('length_rmse_mm')),
                     _opt(m.get('stiffness_rmse_kN_per_m')))
                    for m in sorted(s['laws'], key=lambda m: m['rmse_N'])])
    return lines


def _opt(v: float | None) -> str:
    return '-' if v is None else f'{v:.2f}'


def straight_fibre_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result row: prototype figures within tolerance."""
    figs = r.get('straight_fibre', {}).get('figures')
    if not figs:
        return []
    ok = sum(1 for f in figs if f['ok'])
    return [("000's straight-fibre prototype through the nodes: figures within tolerance",
             f'{len(figs)} of {len(figs)}', f'{ok} of {len(figs)}', commit)]


STUDY = Study(
    'straight_fibre', "000's straight-fibre prototype through the nodes, against 000's figures",
    lambda quick, out, scenes: {'straight_fibre': measure_straight_fibre(out)},
    (('straight_fibre', lambda r, root: straight_fibre_section(r)),),
    lambda r: straight_fibre_results(r, commit_of(r, 'straight_fibre')))
"""The straight-fibre muscle (bench.json ``straight_fibre``)."""
