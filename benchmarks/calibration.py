"""Study ``calibration``: every figure 004 reports, on the simulated bench (``verify``)."""

from __future__ import annotations

import pathlib
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.verify.calibration import calibration_figures

__all__ = ['STUDY', 'measure', 'section', 'results']


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """004's figures on its full grids (quasi-static) and on a coarse dynamic grid."""
    from pam_bench.verify.figures_004 import figure_rows, measure_004
    measured = measure_004()
    return {'calibration': {**calibration_figures(), 'figures_004': figure_rows(measured),
                            'secant_004': measured['isometric_gain_secant_by_x'],
                            'isotonic_min_at': [measured['isotonic_gain_min_u'],
                                                measured['isotonic_gain_min_f']]}}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """Each figure beside 004's, then the coarse dynamic grid."""
    c = r['calibration']
    lines: list[str] = []
    if c.get('figures_004'):
        lines += ["Every figure 004 reports, on its full grids (quasi-static bench, the "
                  "extraction's estimators; `verify/figures_004.py` says how each is read):", '']
        lines += table(['figure', '004', 'simulated bench', 'difference', 'tolerance',
                        'within'],
                       [(f['text'], f"{f['paper']:g} {f['unit']}",
                         f"{f['bench']:.4g} {f['unit']}",
                         f"{f['difference'] * 100:+.1f} %" if f['relative']
                         else f"{f['difference']:+.3g} {f['unit']}",
                         '>= 004' if f['at_least'] else f"{f['tolerance'] * 100:g} %"
                         if f['relative'] else f"{f['tolerance']:g} {f['unit']}",
                         'yes' if f['ok'] else 'NO') for f in c['figures_004']])
        sec = c.get('secant_004', {})
        if sec:
            lines += ['', f"004 words the isometric gain as the ratio F/u; read literally as "
                      f"the secant F(6 V) / 6 V it is {sec['0']:.1f} N/V at 0 mm and "
                      f"{sec['95']:.1f} N/V at 95 mm (the slope reading above is the one 004's "
                      '"F ~ k(x) u + F0" fits). The isotonic ratio x/u has no value at u = 0, '
                      "where 004 places its minimum, so it is read as the difference quotient "
                      'between neighbouring readings; the smallest lies at '
                      f"({c['isotonic_min_at'][0]:.2f} V, {c['isotonic_min_at'][1]:.0f} N), "
                      'equal to the 100 N value to 0.001 mm/V.', '',
                      'The dynamic bench on a coarse grid (0.5 V steps, 3 s dwell):', '']
    return lines + table(['figure', 'simulated bench', '004', 'tolerance'], [
        ('isometric gain at x = 0 mm', f"{c['isometric_gain_N_per_V_at_0mm']:.1f} N/V",
         '284.3 N/V', '+-10 % (coarse grid)'),
        ('isometric gain at x = 95 mm', f"{c['isometric_gain_N_per_V_at_95mm']:.1f} N/V",
         '17.4 N/V', '+-10 % (coarse grid)'),
        ('contraction at 6 V, 50 N', f"{c['contraction_mm_at_6V_50N']:.1f} mm", '>= 100 mm',
         '-'),
        ('force at 6 V, x = 0', f"{c['force_N_at_6V_0mm']:.0f} N", '>= 900 N', '-'),
        ('isobaric hysteresis, max', f"{c['isobaric_hysteresis_mm_max']:.2f} mm", 'visible',
         '-')])


def results(r: dict[str, Any]) -> list[Row]:
    """004's figures within their tolerances, and the coarse dynamic grid's four."""
    c = r.get('calibration')
    if not c:
        return []
    commit = commit_of(r, 'calibration')
    rows: list[Row] = []
    if c.get('figures_004'):
        ok = sum(1 for f in c['figures_004'] if f['ok'])
        rows.append(("004's figures on its full grids within issue 18's tolerances",
                     f"{len(c['figures_004'])} of {len(c['figures_004'])}",
                     f"{ok} of {len(c['figures_004'])}", commit))
    return rows + [
        ('isometric gain at x = 0 mm, dynamic bench on a 0.5 V grid', '284.3 N/V (004) +-10 %',
         f"{c['isometric_gain_N_per_V_at_0mm']:.1f} N/V", commit),
        ('isometric gain at x = 95 mm, dynamic bench on a 0.5 V grid', '17.4 N/V (004) +-10 %',
         f"{c['isometric_gain_N_per_V_at_95mm']:.1f} N/V", commit),
        ('contraction at 6 V, 50 N', '>= 100 mm (004)',
         f"{c['contraction_mm_at_6V_50N']:.1f} mm", commit),
        ('force at 6 V, x = 0', '>= 900 N (004)', f"{c['force_N_at_6V_0mm']:.0f} N", commit)]


STUDY = Study('calibration', 'every 004 figure on the simulated bench', measure,
              (('calibration', section),), results)
"""The bench against 004 (bench.json ``calibration``)."""
