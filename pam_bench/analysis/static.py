"""Static characteristics of 004 section 2.2 from characteristic points.

- isometric gain k(x) (N/V): least-squares slope of F over u per series, taken on the
  hysteresis midline so the friction of the braid cancels (see ``isometric_gains``);
- isotonic gain k(u, F) (mm/V): dx/du between neighbouring readings of the up sweep, placed at
  the mid voltage;
- isobaric hysteresis (mm): x on the way down minus x on the way up at the same set force;
- isobaric stiffness (N/m): -dF/dx between neighbouring readings of one branch (loading up,
  unloading down) of each constant-voltage series, placed at the mid force: how stiff the
  muscle is at that pressure and load (the stiffness 003 Eq. 19 predicts).
"""

from __future__ import annotations

from typing import Any, TypedDict

import numpy as np

from pam_bench.bags.bagread import Points

__all__ = ['kind_of', 'KINDS', 'isometric_gains', 'isometric_lines', 'midline_fit',
           'isotonic_gains', 'isobaric_hysteresis', 'isobaric_stiffness', 'gain_summary',
           'GainSummary']


class GainSummary(TypedDict, total=False):
    """The static characteristics found, a key per protocol kind the bags hold (see
    ``gain_summary``)."""

    isometric: dict[str, Any]
    isotonic: dict[str, Any]
    isobaric: dict[str, Any]


MIN_DX_M = 1e-6
"""A neighbouring pair of readings closer than this in contraction gives no stiffness (m)."""


def isometric_gains(p: Points) -> tuple[np.ndarray, np.ndarray]:
    """(x in m, gain in N/V) per series, shapes (n_series,).

    With both sweeps present the gain is the slope of the hysteresis midline
    (F_up(u) + F_down(u)) / 2 over the readings where both branches pull (F > 1 % of the
    series' largest force), leaving out the top 30 % of that voltage range and every voltage
    at or above the down sweep's largest force: there the braid friction is still changing
    side after the turn of the sweep, so the branches are not yet parallel (near full
    contraction the backbone gain is so small that the down sweep first rises while the
    friction turns round, over up to 40 % of the range at x = 110 mm). Where the friction has
    fully slipped it adds +-(f0 + mu F) to the two branches and cancels in the midline. With
    one sweep only: the slope of that sweep where it pulls.
    """
    x, k, _ = isometric_lines(p)
    return x, k


def isometric_lines(p: Points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x in m, gain k in N/V, intercept F0 in N) of F = k u + F0 per series (see
    ``isometric_gains``), shapes (n_series,)."""
    xs, ks, f0s = [], [], []
    for s in np.unique(p.series):
        m = p.series == s
        line = midline_fit(p.voltage_v[m], p.force_n[m], p.direction[m])
        if line is not None:
            xs.append(float(p.series_value[m][0]))
            ks.append(line[0])
            f0s.append(line[1])
    return np.array(xs), np.array(ks), np.array(f0s)


def midline_fit(u: np.ndarray, f: np.ndarray, direction: np.ndarray
             ) -> tuple[float, float] | None:
    """(slope N/V, intercept N) of one isometric series (None: too few usable readings)."""
    floor = 0.01 * max(float(f.max()), 1e-9)
    up = {round(float(a), 6): float(b) for a, b, d in zip(u, f, direction, strict=True)
          if d == 0}
    down = {round(float(a), 6): float(b) for a, b, d in zip(u, f, direction, strict=True)
            if d == 1}
    both = sorted(v for v in set(up) & set(down) if up[v] > floor and down[v] > floor)
    if len(both) >= 4:
        uu = np.array(both)
        mid = np.array([(up[v] + down[v]) / 2.0 for v in both])
        u_turned = uu[int(np.argmax([down[v] for v in both]))]
        keep = (uu <= uu[0] + 0.7 * (uu[-1] - uu[0])) & (uu < u_turned)
        if keep.sum() >= 3:
            k, f0 = np.polyfit(uu[keep], mid[keep], 1)
            return float(k), float(f0)
    use = f > floor
    if use.sum() >= 2 and np.ptp(u[use]) > 0:
        k, f0 = np.polyfit(u[use], f[use], 1)
        return float(k), float(f0)
    return None


def isotonic_gains(p: Points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u mid in V, F in N, gain in mm/V) over all series' up sweeps, shapes (n,)."""
    us, fs, ks = [], [], []
    for s in np.unique(p.series):
        m = (p.series == s) & (p.direction == 0)
        order = np.argsort(p.voltage_v[m])
        u, x = p.voltage_v[m][order], p.contraction_m[m][order]
        du = np.diff(u)
        ok = du > 0
        us.extend((0.5 * (u[1:] + u[:-1]))[ok])
        fs.extend([float(p.series_value[m][0])] * int(ok.sum()))
        ks.extend((np.diff(x)[ok] / du[ok]) * 1e3)
    return np.array(us), np.array(fs), np.array(ks)


def isobaric_hysteresis(p: Points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u in V, F in N, x_down - x_up in mm) at every set force read both ways."""
    us, fs, hs = [], [], []
    for s in np.unique(p.series):
        m = p.series == s
        up = {round(v, 6): x for v, x, d in zip(p.set_value[m], p.contraction_m[m],
                                               p.direction[m], strict=True) if d == 0}
        down = {round(v, 6): x for v, x, d in zip(p.set_value[m], p.contraction_m[m],
                                                 p.direction[m], strict=True) if d == 1}
        for f in sorted(set(up) & set(down)):
            us.append(float(p.series_value[m][0]))
            fs.append(f)
            hs.append((down[f] - up[f]) * 1e3)
    return np.array(us), np.array(fs), np.array(hs)


def isobaric_stiffness(p: Points) -> list[dict[str, Any]]:
    """Per series (u V) and branch (0 up, 1 down): the mid forces (N) and -dF/dx (N/m)
    between neighbouring readings in force order."""
    out = []
    for s in np.unique(p.series):
        for d in (0, 1):
            m = (p.series == s) & (p.direction == d)
            if m.sum() < 2:
                continue
            order = np.argsort(p.force_n[m])
            f, x = p.force_n[m][order], p.contraction_m[m][order]
            df, dx = np.diff(f), np.diff(x)
            ok = np.abs(dx) > MIN_DX_M
            out.append({'u_V': float(p.series_value[m][0]), 'branch': 'loading' if d == 0
                        else 'unloading', 'force_N': (0.5 * (f[1:] + f[:-1]))[ok].tolist(),
                        'stiffness_N_per_m': (-df[ok] / dx[ok]).tolist()})
    return out


KINDS = ('isometric', 'isotonic', 'isobaric')
"""The three static families of 004 (section 2.2)."""
HELD_X_M = 1.0e-3
"""An unnamed protocol is isometric when every reading sits this close to its series' x (m)."""
HELD_F_REL = 0.05
"""... isotonic when every force sits this close (relative, at least 10 N) to its series'."""


def kind_of(p: Points) -> str | None:
    """Which family a protocol's readings are: by its name (``isometric_quick``), else by what
    they hold (a protocol of another name, the README demo's ramp at 20 mm among them): u
    swept with x held at the series value is isometric, with F held isotonic; F swept at a
    held u is isobaric. None: none of them."""
    for kind in KINDS:
        if p.protocol.startswith(kind):
            return kind
    if len(p) < 2:
        return None
    if np.allclose(p.set_value, p.voltage_v, rtol=0.0, atol=1e-6):          # u swept
        if np.max(np.abs(p.contraction_m - p.series_value)) <= HELD_X_M:
            return 'isometric'
        tol = np.maximum(HELD_F_REL * np.abs(p.series_value), 10.0)
        if np.all(np.abs(p.force_n - p.series_value) <= tol):
            return 'isotonic'
    elif np.allclose(p.series_value, p.voltage_v, rtol=0.0, atol=1e-6):     # F swept
        return 'isobaric'
    return None


def gain_summary(points: dict[str, Points]) -> GainSummary:
    """The static part of summary.json for whichever protocols are present (``kind_of``)."""
    out = GainSummary()
    # when a kind appears more than once (full and quick grids), the largest protocol wins
    for name, p in sorted(points.items(), key=lambda kv: len(kv[1])):
        kind = kind_of(p)
        if kind == 'isometric':
            x, k = isometric_gains(p)
            if len(k):
                i, j = int(np.argmax(k)), int(np.argmin(k))
                out['isometric'] = {'protocol': name, 'gain_N_per_V': {
                    'max': float(k[i]), 'x_mm_at_max': float(x[i] * 1e3),
                    'min': float(k[j]), 'x_mm_at_min': float(x[j] * 1e3)},
                    'series': [{'x_mm': float(a * 1e3), 'gain_N_per_V': float(b)}
                               for a, b in zip(x, k, strict=True)]}
        elif kind == 'isotonic':
            u, f, k = isotonic_gains(p)
            if len(k):
                i, j = int(np.argmax(k)), int(np.argmin(k))
                out['isotonic'] = {'protocol': name, 'gain_mm_per_V': {
                    'max': float(k[i]), 'u_V_at_max': float(u[i]), 'F_N_at_max': float(f[i]),
                    'min': float(k[j]), 'u_V_at_min': float(u[j]), 'F_N_at_min': float(f[j])}}
        elif kind == 'isobaric':
            _, _, h = isobaric_hysteresis(p)
            if len(h):
                out['isobaric'] = {'protocol': name,
                                   'hysteresis_mm_max': float(np.max(np.abs(h)))}
                stiff = isobaric_stiffness(p)
                every = [k for c in stiff for k in c['stiffness_N_per_m']]
                if every:
                    out['isobaric']['stiffness'] = {
                        'min_N_per_m': float(min(every)), 'max_N_per_m': float(max(every)),
                        'curves': stiff}
    return out
