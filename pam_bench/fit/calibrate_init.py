"""Where a bag calibration starts: initial values read off the data, not the bench's defaults.

A lab's muscle can lie far from 004's; a local fit started at the defaults then stops in a
minimum of its own. Each parameter the readings show directly is estimated from them first
(``initial_values``), with the extraction's own estimators where there is one:

- the gain curve g(x): at each isometric position the midline F(u) (the mean of the up and the
  down branch, which cancels most of the braid friction) is a straight line in u above the
  contact band, F = g(x) (k_v u - p_0) - k_bl x (``models.muscle``, e(p) -> p - p_0 for
  p >> p_th), so its slope over the upper voltages gives g(x) = slope / k_v; a least-squares
  fit of g(x) = g_m + (g_0 - g_m)(1 - x / x_m)^n to those gains gives g_0, g_m, x_m and n
  (g_m and x_m only when the positions reach past the minimum: otherwise the curve cannot
  place it, and they keep their starting values);
- p_0 and the bladder stiffness k_bl: the lines' intercepts, -g(x_i) p_0 - k_bl x_i, are
  linear in the two (least squares over the positions);
- the contact threshold p_th and band w: at low voltage, on both branches, the effective
  pressure each reading implies, e = (F + k_bl x) / g(x), against the commanded pressure
  (least squares of e(p) = w S((p - p_th) / w) - w S(-p_th / w) on the readings below
  p_0 + 3 w, S the softplus);
- the valve's loop from the step records: 004's F'' + b F' + c F = d u fitted to each record
  (``analysis.identify.fit_step``) gives the loop's sqrt(c) and b / (2 sqrt(c)), scaled back
  to the reference volume (``models.valve``: w ~ sqrt(V_ref / V)); the median over records;
- the friction's stiffness scale from the hysteresis width: the mean up-minus-down force at the
  isometric readings against the same width of the model at these estimates, for a few
  scales, the nearest kept.

What the data cannot show keeps the starting value it was given. Each estimate is clipped to
its fit interval (``FREE_BAGS``).
"""

from __future__ import annotations

import dataclasses
import math
from collections import defaultdict
from collections.abc import Callable, Sequence

import numpy as np
from scipy.optimize import least_squares

from pam_bench.models.laws.base import ForceLaw
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.valve import ValveParams

__all__ = ['initial_values', 'law_start', 'isometric_lines', 'Start']

Start = dict[str, float]
"""Parameter name (``FREE_BAGS``) -> initial value."""
UPPER_SHARE = 0.5
"""The upper share of an isometric series' voltages the gain is read on (above the band)."""
MIN_FORCE_N = 5.0
"""A reading below this force says nothing about the gain (the muscle slack or below p_th)."""


def _softplus(z: np.ndarray) -> np.ndarray:
    return np.maximum(z, 0.0) + np.log1p(np.exp(-np.abs(z)))


def isometric_lines(readings: Sequence[tuple[str, float, float, float]]
                    ) -> dict[float, dict[float, list[float]]]:
    """Isometric readings grouped: held x (m) -> u (V) -> the forces read there (up and
    down branch), N."""
    out: dict[float, dict[float, list[float]]] = defaultdict(lambda: defaultdict(list))
    for kind, u, x, f in readings:
        if kind == 'isometric':
            out[round(x, 6)][round(u, 6)].append(f)
    return out


def _gains(lines: dict[float, dict[float, list[float]]], kv: float
           ) -> list[tuple[float, float, float]]:
    """(x m, g N/Pa, intercept N) of each position's midline over its upper voltages."""
    out = []
    for x, by_u in sorted(lines.items()):
        us = np.array(sorted(by_u))
        if len(us) < 4:
            continue
        f = np.array([float(np.mean(by_u[u])) for u in us])
        keep = (us >= us.min() + (1.0 - UPPER_SHARE) * (us.max() - us.min())) & \
            (f > MIN_FORCE_N)
        if keep.sum() < 3:
            continue
        slope, icept = np.polyfit(us[keep], f[keep], 1)
        if slope > 0.0:
            out.append((x, float(slope / kv), float(icept)))
    return out


def _gain_curve(gains: list[tuple[float, float, float]], start: Start,
                bounds: dict[str, tuple[float, float]]) -> Start:
    """g_0, g_m, x_m, n from the gains per position (module docstring)."""
    x = np.array([g[0] for g in gains])
    g = np.array([g[1] for g in gains])
    out: Start = {}
    x0 = int(np.argmin(np.abs(x)))
    if abs(x[x0]) < 5e-3:
        out['gain_n_per_pa'] = float(g[x0])
    if len(x) < 3:
        return out
    names = ['gain_n_per_pa', 'gain_min_n_per_pa', 'gain_min_contraction_m', 'gain_exponent']
    reach = bool(np.argmin(g) < len(g) - 1)      # the gains turn up again inside the grid
    free = names if reach else [n for n in names if n not in ('gain_min_n_per_pa',
                                                              'gain_min_contraction_m')]
    fixed = {n: start[n] for n in names if n not in free}

    def curve(theta: np.ndarray) -> np.ndarray:
        p = {**fixed, **dict(zip(free, theta, strict=True))}
        r = np.clip(1.0 - x / p['gain_min_contraction_m'], 0.0, None)
        return p['gain_min_n_per_pa'] + (p['gain_n_per_pa'] - p['gain_min_n_per_pa']) * \
            r ** p['gain_exponent']

    lo = np.array([bounds[n][0] for n in free])
    hi = np.array([bounds[n][1] for n in free])
    x_start = np.clip([out.get(n, start[n]) for n in free], lo, hi)
    sol = least_squares(lambda th: (curve(th) - g) / g.max(), x_start, bounds=(lo, hi))
    out.update(dict(zip(free, map(float, sol.x), strict=True)))
    return out


def _offset_and_bladder(gains: list[tuple[float, float, float]], kv: float
                        ) -> tuple[float, float] | None:
    """(p_0 Pa, k_bl N/m) from the intercepts of the lines (in u: icept = -g p_0 - k_bl x)."""
    if len(gains) < 2:
        return None
    a = np.array([[gi, xi] for xi, gi, _ in gains])
    b = -np.array([ic for _, _, ic in gains])
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    return float(sol[0]), float(sol[1])


def _threshold(lines: dict[float, dict[float, list[float]]], gains: list[tuple[float, float,
                                                                              float]],
               kv: float, kbl: float, p0: float, start: Start,
               bounds: dict[str, tuple[float, float]]) -> Start:
    """p_th and w from the low-voltage readings on both branches (module docstring)."""
    gain_at = {x: g for x, g, _ in gains}
    p, e = [], []
    for x, by_u in lines.items():
        g = gain_at.get(x)
        if g is None or g <= 0.0:
            continue
        for u, forces in by_u.items():
            for f in forces:
                if f > MIN_FORCE_N:
                    p.append(kv * u)
                    e.append((f + kbl * x) / g)
    if len(p) < 4:
        return {}
    pa, ea = np.array(p), np.array(e)

    def model(th: np.ndarray) -> np.ndarray:
        pth, w = th
        w = max(w, 1.0)
        return w * (_softplus((pa - pth) / w) - _softplus(np.array(-pth / w)))

    keep = pa <= max(p0, 0.0) + 3.0 * max(start['threshold_width_pa'], 1e4)
    if keep.sum() < 4:
        keep = np.ones_like(pa, bool)
    pa, ea = pa[keep], ea[keep]
    lo = np.array([bounds['threshold_pressure_pa'][0], max(bounds['threshold_width_pa'][0],
                                                           1.0)])
    hi = np.array([bounds['threshold_pressure_pa'][1], bounds['threshold_width_pa'][1]])
    th0 = np.clip([start['threshold_pressure_pa'], max(start['threshold_width_pa'], 1e3)],
                  lo, hi)
    sol = least_squares(lambda th: (model(th) - ea) / 1e4, th0, bounds=(lo, hi))
    return {'threshold_pressure_pa': float(sol.x[0]), 'threshold_width_pa': float(sol.x[1])}


def _valve(records: Sequence[tuple[float, float, float, float, np.ndarray]],
           valve: ValveParams, muscle: MuscleParams) -> Start:
    """The valve loop's natural frequency (at the reference volume) and damping from the step
    fits (module docstring)."""
    from pam_bench.analysis.identify import fit_step
    model = MuscleModel(muscle)
    wn, zeta = [], []
    for x, u0, u1, period, samples in records:
        if u1 == u0 or len(samples) < 20:
            continue
        try:
            fit = fit_step(samples, period, u1 - u0)
        except ValueError:
            continue
        if fit.c <= 0.0:
            continue
        w = math.sqrt(fit.c)
        if valve.volume_scaling:
            total = valve.line_volume_m3 + model.volume(x)
            w /= math.sqrt(valve.reference_volume_m3 / total)
        wn.append(w)
        zeta.append(fit.b / (2.0 * math.sqrt(fit.c)))
    if not wn:
        return {}
    return {'natural_frequency_rad_s': float(np.median(wn)),
            'damping_ratio': float(np.median(zeta))}


def _friction_width(lines: dict[float, dict[float, list[float]]]) -> float | None:
    """Mean |up - down| of the isometric readings read twice at the same (x, u), N."""
    widths = [abs(f[0] - f[-1]) for by_u in lines.values() for f in by_u.values()
              if len(f) >= 2 and max(f) > MIN_FORCE_N]
    return float(np.mean(widths)) if widths else None


def _friction_scale(readings: Sequence[tuple[str, float, float, float]], width: float,
                    valve: ValveParams, muscle: MuscleParams,
                    bounds: tuple[float, float]) -> float | None:
    """The stiffness scale whose model loop width is nearest the measured one (a few scales
    tried on the quasi-static bench over the isometric readings)."""
    from pam_bench.twin.quasistatic import QuasiStaticBench
    iso = [(u, x) for kind, u, x, _ in readings if kind == 'isometric']
    if len(iso) < 4:
        return None
    best, best_err = None, math.inf
    for scale in np.geomspace(max(bounds[0], 1e-3), bounds[1], 6):
        m = dataclasses.replace(muscle, friction_stiffness_n_per_m=[
            k * scale for k in muscle.friction_stiffness_n_per_m])
        bench = QuasiStaticBench(valve, m, None, overshoot=True)
        got: dict[tuple[float, float], list[float]] = defaultdict(list)
        for u, x in iso:
            got[(round(x, 6), round(u, 6))].append(bench.hold_position(u, x).force_n)
        widths = [abs(f[0] - f[-1]) for f in got.values() if len(f) >= 2 and max(f) >
                  MIN_FORCE_N]
        if not widths:
            return None
        err = abs(float(np.mean(widths)) - width)
        if err < best_err:
            best, best_err = float(scale), err
    return best


def initial_values(readings: Sequence[tuple[str, float, float, float]],
                   records: Sequence[tuple[float, float, float, float, np.ndarray]],
                   valve: ValveParams, muscle: MuscleParams, start: Start,
                   bounds: dict[str, tuple[float, float]],
                   models: Callable[[Start], tuple[ValveParams, MuscleParams]]
                   ) -> tuple[Start, dict[str, str]]:
    """Initial values read off the observations (module docstring).

    Args:
        readings: (kind, u V, held load or x, value) in time order (``Observations``).
        records: (x m, u0 V, u1 V, period s, force samples N) of the step records.
        valve: the bench's valve (its gain k_v, its volume scaling).
        muscle: the bench's muscle (its geometry, its friction elements).
        start: every free parameter's value before (the defaults, or a prior).
        bounds: name -> (lower, upper) of the fit intervals.
        models: the valve and muscle of a set of values (``calibrate_bags``).

    Returns:
        The start with every estimate the data allowed, clipped to its interval, and for
        each parameter estimated, what it was read from.
    """
    kv = valve.gain_pa_per_v
    out, why = dict(start), {}
    lines = isometric_lines(readings)
    gains = _gains(lines, kv)
    if gains and all(n in out for n in _GAIN_NAMES):
        est = _gain_curve(gains, out, bounds)
        out.update(est)
        why.update({n: 'isometric gains per position' for n in est})
        ob = _offset_and_bladder(gains, kv)
        if ob is not None and 'bladder_stiffness_n_per_m' in out and \
                bounds['bladder_stiffness_n_per_m'][0] <= ob[1]:
            out['bladder_stiffness_n_per_m'] = ob[1]
            why['bladder_stiffness_n_per_m'] = 'intercepts of the isometric lines'
        if ob is not None and 'threshold_pressure_pa' in out and 'threshold_width_pa' in out:
            kbl = out.get('bladder_stiffness_n_per_m', muscle.bladder_stiffness_n_per_m)
            est = _threshold(lines, gains, kv, kbl, ob[0], out, bounds)
            out.update(est)
            why.update({n: 'isometric F(u) at low voltage, both branches' for n in est})
    if 'natural_frequency_rad_s' in out and 'damping_ratio' in out:
        est = _valve(records, valve, muscle)
        out.update(est)
        why.update({n: 'step fits (004 Eq. 2)' for n in est})
    for name in out:
        lo, hi = bounds[name]
        out[name] = float(min(max(out[name], lo), hi))
    width = _friction_width(lines)
    if width is not None and 'friction_stiffness_scale' in out:
        v, m = models({k: w for k, w in out.items() if k != 'friction_stiffness_scale'})
        scale = _friction_scale(readings, width, v, m, bounds['friction_stiffness_scale'])
        if scale is not None:
            out['friction_stiffness_scale'] = scale
            why['friction_stiffness_scale'] = 'hysteresis width of the isometric readings'
    return out, why


_GAIN_NAMES = ('gain_n_per_pa', 'gain_min_n_per_pa', 'gain_min_contraction_m', 'gain_exponent')


def _branch_means(iso: list[tuple[float, float, float]]) -> list[tuple[float, float, float]]:
    """Isometric readings (u, x, F) with the rising and falling readings at one (u, x) replaced
    by their mean: the braid's friction pulls the two branches apart by about as much either
    way, so the mean stands nearer the law's frictionless force than either (a law fitted to
    both branches bends to the loop instead)."""
    groups: dict[tuple[float, float], list[float]] = {}
    for u, x, f in iso:
        groups.setdefault((round(u, 9), round(x, 12)), []).append(f)
    return [(u, x, float(np.mean(fs))) for (u, x), fs in groups.items()]


def law_start(law: ForceLaw, readings: Sequence[tuple[str, float, float, float]],
              records: Sequence[tuple[float, float, float, float, np.ndarray]],
              valve: ValveParams, muscle: MuscleParams) -> tuple[Start, dict[str, str]]:
    """Where a fit with the force law ``law`` starts: the law's parameters from its static fit
    to the isometric readings (the extraction's, ``analysis.force_models``), named
    'LAW.PARAMETER', and the valve's loop from the step fits (module docstring).

    Returns:
        The estimates the data allowed and what each was read from.
    """
    from pam_bench.analysis.force_models import fit_force_models
    out: Start = {}
    why: dict[str, str] = {}
    iso = _branch_means([(u, x, f) for kind, u, x, f in readings if kind == 'isometric'])
    if len(iso) > len(law.params):
        u, x, f = (np.array(c, float) for c in zip(*iso, strict=True))
        fits = fit_force_models(valve.gain_pa_per_v * u, x, f, muscle.nominal_length_m, (law,))
        if fits:
            for n, v in fits[0]['params'].items():
                out[f'{law.name}.{n}'] = float(v)
                why[f'{law.name}.{n}'] = 'the law fitted to the isometric readings'
    est = _valve(records, valve, muscle)
    out.update(est)
    why.update({n: 'step fits (004 Eq. 2)' for n in est})
    return out, why
