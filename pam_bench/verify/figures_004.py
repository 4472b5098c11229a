"""Every figure 004 reports, read from a bench's parameters on 004's full grids.

The readings are the quasi-static bench's (``pam_bench.twin.quasistatic``: each reading settled
after its dwell, the braid friction carried along the protocol's path), on the grids of
config/protocols.yaml (isometric 0..110 mm by 5 mm, isotonic 50..950 N by 50 N, u 0..6 V by
0.1 V, up then down), and the gains are taken by the extraction's own estimators
(``pam_bench.analysis.static``). How each of 004's words is read (004 section 2.3):

- isometric gain k(x), "the ratio of F to u": the slope of F = k u + F0 (004's own "close to
  linear" fit; the hysteresis midline, ``isometric_gains``), N/V. Reported beside it: the
  secant F(6 V) / 6 V of the midline through the origin, the literal ratio.
- isotonic gain k(u, F), "the ratio of x to u": 004's minimum sits at u = 0 V, where x / u has
  no value, so the ratio is read as the difference quotient between neighbouring readings of
  the up sweep, (x(u + 0.1) - x(u)) / 0.1 V, placed at the mid voltage (``isotonic_gains``);
  mm/V. Both readings are this one.
- contraction: the largest x of the isotonic series at 50 N (the "small load"), at 6 V, mm;
  force: the isometric reading at 0 mm and 6 V, N.
- servo torque: (F_1 - F_2) r at theta = 0 with u_1 = 10 V and u_2 = 0 V (the valve's whole
  range), both muscles at the servo's rest contraction, r the pulley's pitch radius; N m.
- step response: second order and oscillating when the pressure loop's c > b^2 / 4 at every
  step position (``QuasiStaticBench.pressure_dynamics``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from pam_bench.analysis.static import isometric_gains, isometric_lines, isotonic_gains
from pam_bench.bags.bagread import Points
from pam_bench.config.protocols import protocol_schedule
from pam_bench.control.torque_servo import TorqueServoParams
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.quasistatic import QuasiStaticBench

__all__ = ['Figure', 'FIGURES_004', 'measure_004', 'figure_rows']

PULLEY_RADIUS_M = 0.06366 / 2          # 004: pitch diameter 63.66 mm


@dataclasses.dataclass(frozen=True)
class Figure:
    """A figure of 004 with the tolerance the bench must meet (issue 18's done-when)."""

    key: str
    text: str
    paper: float
    unit: str
    tolerance: float              # relative if ``relative``, else absolute in ``unit``
    relative: bool = True
    at_least: bool = False        # a lower bound: the bench must reach ``paper``


FIGURES_004 = (
    Figure('isometric_gain_max', 'isometric gain at 0 mm', 284.3, 'N/V', 0.03),
    Figure('isometric_gain_min', 'isometric gain, minimum over 0..110 mm', 17.4, 'N/V', 0.03),
    Figure('isometric_gain_min_x', 'position of the isometric minimum', 95.0, 'mm', 5.0,
           relative=False),
    Figure('isotonic_gain_max', 'isotonic gain, maximum', 97.16, 'mm/V', 0.10),
    Figure('isotonic_gain_max_u', 'voltage of the isotonic maximum', 0.86, 'V', 0.15,
           relative=False),
    Figure('isotonic_gain_max_f', 'load of the isotonic maximum', 50.0, 'N', 0.0,
           relative=False),
    Figure('isotonic_gain_min', 'isotonic gain, minimum', 0.13, 'mm/V', 0.20),
    Figure('isotonic_gain_at_0v_100n', 'isotonic gain at (0 V, 100 N)', 0.13, 'mm/V', 0.20),
    Figure('contraction_max', 'largest contraction (6 V, 50 N)', 100.0, 'mm', 0.0,
           at_least=True),
    Figure('force_max', 'largest force (6 V, 0 mm)', 900.0, 'N', 0.0, at_least=True),
    Figure('servo_torque_max', 'servo torque reachable (10 V / 0 V, theta = 0)', 25.46, 'N m',
           0.0, at_least=True),
)


def _points(name: str, rows: list[tuple[Any, Any]]) -> Points:
    def col(f: Any) -> np.ndarray:
        return np.array([f(r, s) for r, s in rows])
    return Points(name, col(lambda r, s: 0.0), col(lambda r, s: r.series),
                  col(lambda r, s: r.step), col(lambda r, s: int(r.direction)),
                  col(lambda r, s: r.series_value), col(lambda r, s: r.set_value),
                  col(lambda r, s: s.voltage_v), col(lambda r, s: s.force_n),
                  col(lambda r, s: s.contraction_m), col(lambda r, s: s.pressure_pa))


def _settled(name: str, valve: ValveParams | None, muscle: MuscleParams | None,
             servo: LoadingServoParams | None) -> Points:
    bench = QuasiStaticBench(valve, muscle, servo)
    rows = [(r, bench.settle(r)) for r in protocol_schedule(name, {})[0]]
    return _points(name, rows)


def measure_004(valve: ValveParams | None = None, muscle: MuscleParams | None = None,
                servo: LoadingServoParams | None = None,
                torque: TorqueServoParams | None = None) -> dict[str, Any]:
    """Every figure of ``FIGURES_004`` for a bench's parameters (module docstring), plus the
    second readings (``*_secant``) and where each extreme lies."""
    torque = torque or TorqueServoParams()
    iso = _settled('isometric', valve, muscle, servo)
    xs, ks = isometric_gains(iso)
    _, _, f0s = isometric_lines(iso)
    i_min = int(np.argmin(ks))
    top = np.isclose(iso.voltage_v, iso.voltage_v.max())
    secant = {round(float(v), 6): float(np.mean(iso.force_n[top & (iso.series_value == v)]))
              / float(iso.voltage_v.max()) for v in np.unique(iso.series_value)}
    ton = _settled('isotonic', valve, muscle, servo)
    us, fs, kt = isotonic_gains(ton)
    j_max, j_min = int(np.argmax(kt)), int(np.argmin(kt))
    at = np.flatnonzero(np.isclose(us, 0.05) & np.isclose(fs, 100.0))
    light = (ton.series_value == ton.series_value.min()) & (ton.direction == 0)
    zero = np.isclose(iso.series_value, 0.0) & top
    bench = QuasiStaticBench(valve, muscle, servo)
    f1 = bench.hold_position(10.0, torque.rest_contraction_m).force_n
    f2 = QuasiStaticBench(valve, muscle, servo).hold_position(
        0.0, torque.rest_contraction_m).force_n
    oscillating = []
    for x in np.arange(0.0, 0.0801, 0.005):
        b, c = bench.pressure_dynamics(float(x))
        oscillating.append(c > b * b / 4.0)
    return {
        'isometric_gain_max': float(ks[np.argmin(np.abs(xs))]),
        'isometric_gain_min': float(ks[i_min]), 'isometric_gain_min_x': float(xs[i_min] * 1e3),
        'isometric_gain_by_x': {f'{x * 1e3:.0f}': float(k) for x, k in zip(xs, ks,
                                                                          strict=True)},
        'isometric_intercept_by_x': {f'{x * 1e3:.0f}': float(f) for x, f in zip(xs, f0s,
                                                                               strict=True)},
        'isometric_gain_secant_by_x': {f'{v * 1e3:.0f}': k for v, k in secant.items()},
        'isotonic_by_point': {f'{u:.2f},{f:.0f}': float(k) for u, f, k in zip(us, fs, kt,
                                                                                strict=True)},
        'isotonic_gain_max': float(kt[j_max]), 'isotonic_gain_max_u': float(us[j_max]),
        'isotonic_gain_max_f': float(fs[j_max]),
        'isotonic_gain_min': float(kt[j_min]), 'isotonic_gain_min_u': float(us[j_min]),
        'isotonic_gain_min_f': float(fs[j_min]),
        'isotonic_gain_at_0v_100n': float(kt[at[0]]) if len(at) else float('nan'),
        'contraction_max': float(ton.contraction_m[light].max() * 1e3),
        'force_max': float(iso.force_n[zero].max()),
        'servo_torque_max': float((f1 - f2) * PULLEY_RADIUS_M),
        'servo_muscle_force_at_10v': float(f1),
        'step_oscillating': bool(all(oscillating)),
    }


def figure_rows(measured: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per figure: key, text, paper, bench, unit, difference, tolerance, ok."""
    rows = []
    for f in FIGURES_004:
        v = float(measured[f.key])
        if f.at_least:
            diff, ok = (v - f.paper) / f.paper, v >= f.paper
        elif f.relative:
            diff = (v - f.paper) / f.paper
            ok = abs(diff) <= f.tolerance
        else:
            diff = v - f.paper
            ok = abs(diff) <= f.tolerance + 1e-9
        rows.append({'key': f.key, 'text': f.text, 'paper': f.paper, 'bench': v,
                     'unit': f.unit, 'difference': diff, 'relative': f.relative or f.at_least,
                     'tolerance': f.tolerance, 'at_least': f.at_least, 'ok': bool(ok)})
    return rows
