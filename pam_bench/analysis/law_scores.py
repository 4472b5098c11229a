"""A fitted force law judged on what it was not fitted to: as a length law on the isotonic
readings and as a stiffness law on the isobaric slopes (issue: 003's length and stiffness
laws, 002's branch fits).

- Length: for an isotonic reading (p, F), the law's contraction is the x that solves
  F_law(p, x) = F on 0 <= x <= 1.5 max x_measured (bisection; every law of the zoo falls with x
  there); RMSE against the measured x in mm, over the readings where the law reaches F (the
  others are counted as ``length_unreached``).
- Stiffness: for neighbouring readings i, i + 1 of one isobaric branch in force order, the
  measured -dF/dx = -(F_i+1 - F_i) / (x_i+1 - x_i) against the law's secant across the same
  contractions at the pair's mean pressure; RMSE in kN/m (the slope 003 Eq. 19 describes).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pam_bench.analysis.static import MIN_DX_M
from pam_bench.bags.bagread import Points
from pam_bench.models.laws.base import ForceLaw

__all__ = ['length_rmse_mm', 'stiffness_rmse_kn_per_m', 'score']


def length_rmse_mm(law: ForceLaw, theta: np.ndarray, p: Points, l0: float
                   ) -> tuple[float | None, int]:
    """(RMSE mm or None, readings the law cannot reach) on the isotonic readings ``p``."""
    pulls = (p.force_n > 1.0) & (p.contraction_m >= max(law.min_x_m, 0.0))
    pp, ff, xx = p.pressure_pa[pulls], p.force_n[pulls], p.contraction_m[pulls]
    if not len(ff):
        return None, 0
    lo = np.full_like(ff, max(law.min_x_m, 0.0))
    hi = np.full_like(ff, 1.5 * float(xx.max()))
    with np.errstate(all='ignore'):
        reach = (law.law(theta, pp, lo, l0) >= ff) & (law.law(theta, pp, hi, l0) <= ff)
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            above = law.law(theta, pp, mid, l0) > ff
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    if not reach.any():
        return None, int(len(ff))
    err = 0.5 * (lo + hi)[reach] - xx[reach]
    return float(np.sqrt(np.mean(err ** 2)) * 1e3), int((~reach).sum())


def stiffness_rmse_kn_per_m(law: ForceLaw, theta: np.ndarray, p: Points, l0: float
                            ) -> float | None:
    """RMSE of the law's secant stiffness against the isobaric slopes, kN/m (or None)."""
    errs = []
    for s in np.unique(p.series):
        for d in (0, 1):
            m = (p.series == s) & (p.direction == d) & (p.contraction_m >= law.min_x_m)
            if m.sum() < 2:
                continue
            order = np.argsort(p.force_n[m])
            f, x, pr = p.force_n[m][order], p.contraction_m[m][order], p.pressure_pa[m][order]
            dx = np.diff(x)
            ok = np.abs(dx) > MIN_DX_M
            if not ok.any():
                continue
            pm = 0.5 * (pr[1:] + pr[:-1])[ok]
            with np.errstate(all='ignore'):
                model = -(law.law(theta, pm, x[1:][ok], l0) - law.law(theta, pm, x[:-1][ok], l0))
            errs.append(model / dx[ok] - (-np.diff(f)[ok] / dx[ok]))
    if not errs:
        return None
    e = np.concatenate(errs)
    e = e[np.isfinite(e)]
    return float(np.sqrt(np.mean(e ** 2)) / 1e3) if len(e) else None


def score(fit: dict[str, Any], law: ForceLaw, isotonic: Points | None, isobaric: Points | None,
          l0: float) -> None:
    """Add length_rmse_mm, length_unreached and stiffness_rmse_kN_per_m to a fit's dict."""
    theta = np.array([fit['params'][n] for n in law.params])
    if isotonic is not None:
        fit['length_rmse_mm'], fit['length_unreached'] = length_rmse_mm(law, theta, isotonic, l0)
    if isobaric is not None:
        fit['stiffness_rmse_kN_per_m'] = stiffness_rmse_kn_per_m(law, theta, isobaric, l0)
