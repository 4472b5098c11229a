"""Step records against their exchange step: one exchange per record or one per sample.

A step record is 1 s of force at 1 kHz after a valve step at a held position (004 section
3.1). The valve reports its pressure at every 1 ms sample of an exchange, the muscle and the
drive are solved together on those samples (``models.coupling``) and the load cell measures
every one, so a record needs no 1 ms exchange: the whole second is one exchange. Each row:
one step recorded with exchanges of H against the same step at 1 ms exchanges (both on 1 ms
sub-steps), fitted with 004 Eq. 2 (``analysis.identify.fit_step``).
"""

from __future__ import annotations

import pathlib
import time
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import table
from pam_bench.analysis.identify import fit_step
from pam_bench.models.loading_servo import LoadMode
from pam_bench.twin.bench import SingleMuscleBench

__all__ = ['STUDY', 'CASES', 'record_step', 'record_exchange_table']

# (x m, u0 V, u1 V): 004's identification steps at both ends of the fitted range
CASES = [(0.0, 1.0, 5.0), (0.04, 1.0, 5.0), (0.08, 1.0, 5.0), (0.0, 5.0, 1.0), (0.04, 5.0, 1.0),
         (0.08, 5.0, 1.0)]
PERIOD_S = 0.001


def record_step(x_m: float, u0_v: float, u1_v: float, record_exchange_s: float,
                seed: int = 1) -> tuple[np.ndarray, int]:
    """Settle 3 s at u0, step to u1 and record 1 s at 1 kHz with exchanges of at most
    ``record_exchange_s``.

    Returns:
        (force samples N, shape (1000,), exchanges taken by the record).
    """
    b = SingleMuscleBench(seed=seed)
    b.command_load(LoadMode.POSITION, x_m, now=True)
    b.servo.reset(x_m)
    b.command_valve(u0_v)
    b.run(3.0, 3.0)
    force = {0: b.f_meas}
    b.command_valve(u1_v)
    t0, t_end = b.t, b.t + 1.0
    n = 0
    while b.t < t_end - 1e-9:
        b.step(min(record_exchange_s, t_end - b.t), PERIOD_S)
        n += 1
        for t, f in b.samples:
            force[round((t - t0) / PERIOD_S)] = f
    return np.array([force[i] for i in range(1000)]), n


def record_exchange_table(quick: bool) -> list[dict[str, Any]]:
    """One row per step case and exchange step (module docstring)."""
    steps = [0.01, 1.0] if quick else [0.01, 0.1, 1.0]
    cases = CASES[::2] if quick else CASES
    rows = []
    for x, u0, u1 in cases:
        t0 = time.perf_counter()
        ref, _ = record_step(x, u0, u1, PERIOD_S)
        wall_ref = time.perf_counter() - t0
        fr = fit_step(ref, PERIOD_S, u1 - u0)
        for h in steps:
            t0 = time.perf_counter()
            y, n = record_step(x, u0, u1, h)
            wall = time.perf_counter() - t0
            ft = fit_step(y, PERIOD_S, u1 - u0)
            err = {k: float(getattr(ft, k) / getattr(fr, k) - 1.0) for k in 'bcd'}
            rows.append({'x_mm': 1e3 * x, 'u0_V': u0, 'u1_V': u1, 'record_exchange_s': h,
                         'exchanges': n, 'b_rel_error': err['b'], 'c_rel_error': err['c'],
                         'd_rel_error': err['d'],
                         'max_abs_rel_error': max(abs(v) for v in err.values()),
                         'max_force_difference_N': float(np.max(np.abs(y - ref))),
                         'wall_s': wall, 'wall_s_1ms': wall_ref})
    return rows


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """b, c, d and the force of each record at each record exchange step."""
    return table(['x mm', 'step', 'H', 'exchanges per record', 'largest b, c, d change',
                  'largest force difference', 'wall s (1 ms wall s)'],
                 [(f"{row['x_mm']:.0f}", f"{row['u0_V']:g} -> {row['u1_V']:g} V",
                   f"{1e3 * row['record_exchange_s']:g} ms", row['exchanges'],
                   f"{100 * row['max_abs_rel_error']:.3f} %",
                   f"{row['max_force_difference_N']:.2f} N",
                   f"{row['wall_s']:.2f} ({row['wall_s_1ms']:.2f})")
                  for row in r['record_exchange']])


STUDY = Study('record_exchange', 'step records at longer record exchanges against 1 ms',
              lambda quick, out, scenes: {'record_exchange': record_exchange_table(quick)},
              (('record_exchange', section),))
"""Step records against the record exchange step (bench.json ``record_exchange``)."""
