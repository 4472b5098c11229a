"""The identified inverse model as one YAML file (read by ``pam_bench.control.inverse``).

Dynamic part: the b, c, d, F_a0 polynomials of the step-response fits (004 Eq. 2) and the
working-point voltage u0 of the up steps they came from. Static part: per isometric series the
hysteresis-midline line F = k u + F0 (``static.isometric_lines``), k(x) and F0(x) fitted with
polynomials in the same centred and scaled x (degree up to 5, 004's choice). x in m in the
file (the summary.json polynomials carry x in mm for people; here SI for the servo).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pam_bench.analysis.smoothing import centred_polyfit
from pam_bench.analysis.static import isometric_lines
from pam_bench.analysis.summary import StepSummary
from pam_bench.bags.bagread import Points

__all__ = ['inverse_model_dict', 'smoothing_polynomial']


def smoothing_polynomial(x_m: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    """Polynomial (degree up to 5) in z = (x - x_mid) / x_half fitted to y(x), x in m."""
    p = centred_polyfit(x_m, y)
    return {'coefficients_low_to_high': [float(c) for c in p.coefficients], 'x_mid_m': p.x_mid,
            'x_half_range_m': p.x_half, 'rms_residual': p.rms_residual}


def inverse_model_dict(step: StepSummary | None, isometric: Points | None,
                       u_max_v: float = 6.0) -> dict[str, Any] | None:
    """The inverse_model.yaml mapping, or None when either part cannot be built.

    Args:
        step: summary['step_response'] (fits and polynomials, x in mm).
        isometric: the isometric points.
        u_max_v: upper clamp of the voltage (the protocols' 6 V = 0.6 MPa).
    """
    if not step or not step.get('polynomials') or isometric is None:
        return None
    x_m, k, f0 = isometric_lines(isometric)
    if len(x_m) < 2:
        return None
    dyn: dict[str, Any] = {}
    for key, name in (('b', 'b'), ('c', 'c'), ('d', 'd'), ('F_a0', 'F_a0_N')):
        p = step['polynomials'][key]
        dyn[name] = {'coefficients_low_to_high': p['coefficients_low_to_high'],
                     'x_mid_m': p['x_mid_mm'] * 1e-3,
                     'x_half_range_m': p['x_half_range_mm'] * 1e-3,
                     'rms_residual': p['rms_residual']}
    ups = [f['u0_V'] for f in step['fits'] if f['direction'] == 'up']
    dyn['u0_V'] = float(np.median(ups)) if ups else 1.0
    dyn['equation'] = "u = u0 + (F'' + b F' + c (F - F_a0)) / d   (004 Eq. 2)"
    return {'pam_bench_inverse_model': 1, 'units': 'SI: x m, F N, u V, t s',
            'u_min_V': 0.0, 'u_max_V': u_max_v, 'dynamic': dyn,
            'static': {'equation': 'u = (F - F0) / k   (isometric midline)',
                       'k_N_per_V': smoothing_polynomial(x_m, k),
                       'F0_N': smoothing_polynomial(x_m, f0)}}
