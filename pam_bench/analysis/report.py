"""report.md of an extraction: the figures embedded, the figures of merit in tables."""

from __future__ import annotations

from pam_bench.analysis.summary import Summary

__all__ = ['report_markdown']


def report_markdown(s: Summary) -> str:
    """The human report of an extraction: figures, gains, fits, model comparison."""
    lines = ['# Extracted characteristics', '']
    if 'isometric' in s:
        g = s['isometric']['gain_N_per_V']
        if len(s['isometric'].get('series', [])) == 1:
            lines += [f"Isometric gain at x = {g['x_mm_at_max']:.0f} mm: {g['max']:.1f} N/V "
                      f"(protocol {s['isometric']['protocol']}, one series).", '']
        else:
            lines += [f"Isometric gain: max {g['max']:.1f} N/V at x = {g['x_mm_at_max']:.0f} "
                      f"mm, min {g['min']:.1f} N/V at x = {g['x_mm_at_min']:.0f} mm.", '']
    if 'isotonic' in s:
        g = s['isotonic']['gain_mm_per_V']
        lines += [f"Isotonic gain: max {g['max']:.2f} mm/V at u = {g['u_V_at_max']:.2f} V, "
                  f"F = {g['F_N_at_max']:.0f} N; min {g['min']:.2f} mm/V at "
                  f"u = {g['u_V_at_min']:.2f} V, F = {g['F_N_at_min']:.0f} N.", '']
    if 'isobaric' in s:
        lines += [f"Isobaric hysteresis: up to {s['isobaric']['hysteresis_mm_max']:.2f} mm.", '']
        st = s['isobaric'].get('stiffness')
        if st:
            lines += [f"Isobaric stiffness -dF/dx: {st['min_N_per_m'] / 1e3:.1f} .. "
                      f"{st['max_N_per_m'] / 1e3:.1f} kN/m over {len(st['curves'])} branch "
                      'curves (summary.json, isobaric.stiffness).', '']
    if 'step_response' in s:
        lines += ['| x mm | direction | u0 -> u1 V | b 1/s | c 1/s^2 | d N/(V s^2) | F_a0 N | '
                  'RMS N |', '|---|---|---|---|---|---|---|---|']
        for f in s['step_response']['fits']:
            lines.append(f"| {f['x_mm']:.0f} | {f['direction']} | {f['u0_V']:.1f} -> "
                         f"{f['u1_V']:.1f} | {f['b']:.2f} | {f['c']:.1f} | {f['d']:.0f} | "
                         f"{f['F_a0_N']:.1f} | {f['rms_error_N']:.3f} |")
        lines.append('')
        polys = s['step_response'].get('polynomials', {})
        if polys:
            lines += ['Polynomials over z = (x - x_mid) / x_half (largest up step per position):',
                      '', '| coefficient | degree | coefficients, low to high | RMS residual |',
                      '|---|---|---|---|']
            for key, p in polys.items():
                coef = ', '.join(f'{c:.4g}' for c in p['coefficients_low_to_high'])
                lines.append(f"| {key} | {p['degree']} | {coef} | {p['rms_residual']:.4g} |")
            lines.append('')
    if 'model_comparison' in s:
        l0 = s.get('model_comparison_length_m')
        lines += ['## Static force models', '',
                  'Fitted to the isometric, isobaric and isotonic readings pooled'
                  + (f' (l0 = {l0 * 1e3:.0f} mm)' if l0 else '') + '; length: the law solved '
                  'for x on the isotonic readings; stiffness: its secant -dF/dx against the '
                  'isobaric slopes (003 Eq. 19).', '',
                  '| model | seed | parameters | RMSE N | max error N | length RMSE mm | '
                  'stiffness RMSE kN/m | fit s | readings |', '|---' * 9 + '|']
        for m in sorted(s['model_comparison'], key=lambda m: m['rmse_N']):
            lines.append(f"| {m['model']} | {m['seed']} | {m['n_params']} | {m['rmse_N']:.2f} | "
                         f"{m['max_error_N']:.1f} | {_opt(m.get('length_rmse_mm'))} | "
                         f"{_opt(m.get('stiffness_rmse_kN_per_m'))} | {m['fit_s']:.3f} | "
                         f"{m['n_points']} |")
        lines += ['', 'Parameters with their standard errors:', '']
        for m in sorted(s['model_comparison'], key=lambda m: m['rmse_N']):
            se = m.get('stderr', {})
            lines.append(f"- {m['model']}: " + ', '.join(
                f'{k} = {v:.4g} +- {se.get(k, float("nan")):.2g}'
                for k, v in m['params'].items()))
        lines.append('')
    if s.get('model_comparison_by_branch'):
        pooled = {m['model']: m['rmse_N'] for m in s.get('model_comparison', [])}
        lines += ['Fitted to each branch apart (loading: the sweep up, unloading: down; 002 '
                  'Fig. 11):', '', '| model | RMSE pooled N | RMSE loading N | RMSE unloading N |',
                  '|---|---|---|---|']
        for m in s['model_comparison_by_branch']:
            lines.append(f"| {m['model']} | {pooled.get(m['model'], float('nan')):.2f} | "
                         f"{m['loading_rmse_N']:.2f} | {m['unloading_rmse_N']:.2f} |")
        lines += ['', 'Branch parameters with their standard errors (loading; unloading):', '']
        for m in s['model_comparison_by_branch']:
            for branch in ('loading', 'unloading'):
                se = m.get(f'{branch}_stderr', {})
                lines.append(f"- {m['model']}, {branch}: " + ', '.join(
                    f'{k} = {v:.4g} +- {se.get(k, float("nan")):.2g}'
                    for k, v in m[f'{branch}_params'].items()))
        lines.append('')
    if s.get('inverse_model'):
        lines += [f"Inverse model for the torque servo: `{s['inverse_model']}`.", '']
    if s.get('figures'):
        lines += ['## Figures', '']
        lines += [f'![{name}]({name})' for name in s['figures']]
        lines.append('')
    t = s.get('timing_s', {})
    if t:
        lines += ['Timing: ' + ', '.join(f'{k} {v:.2f} s' if isinstance(v, float) else f'{k} {v}'
                                         for k, v in t.items()), '']
    return '\n'.join(lines) + '\n'


def _opt(v: float | None) -> str:
    return '-' if v is None else f'{v:.2f}'
