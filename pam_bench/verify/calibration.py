"""What the simulated bench implies for the 004 figures, measured on the numpy bench.

Each figure is read the way the protocol reads it: set the held quantity, step the swept one,
wait a dwell, read the sensors (load cell, encoder). Gains are least-squares slopes of the
readings on the hysteresis midline, as the extraction takes them (pam_bench.analysis.static).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pam_bench.analysis.static import midline_fit
from pam_bench.models.loading_servo import LoadMode
from pam_bench.twin.bench import SingleMuscleBench

__all__ = ['isometric_sweep', 'isotonic_sweep', 'isobaric_sweep', 'isometric_gain',
           'calibration_figures']


def _voltage_sweep(mode: LoadMode, load: float, voltages_v: np.ndarray, dwell_s: float,
                   h_s: float, read_force: bool, **bench_kw: Any) -> tuple[np.ndarray, np.ndarray]:
    """Hold the load (mode, set value), step u up then down; return (u, reading) where the
    reading is the load-cell force (N) or the encoder contraction (m), shapes (2 n,)."""
    b = SingleMuscleBench(**bench_kw)
    b.command_load(mode, load)
    b.run(2.0, h_s)
    us = np.concatenate([voltages_v, voltages_v[::-1]])
    out = []
    for u in us:
        b.command_valve(float(u))
        st = b.run(dwell_s, h_s)
        out.append(st.measured_force_n if read_force else st.measured_angle_rad * b.servo.r)
    return us, np.array(out)


def isometric_sweep(x_m: float, voltages_v: np.ndarray, dwell_s: float = 3.0,
                    h_s: float = 0.01, **bench_kw: Any) -> tuple[np.ndarray, np.ndarray]:
    """Hold x, step u up then down; return (u, F) readings, shapes (2 n,)."""
    return _voltage_sweep(LoadMode.POSITION, x_m, voltages_v, dwell_s, h_s, True, **bench_kw)


def isotonic_sweep(force_n: float, voltages_v: np.ndarray, dwell_s: float = 3.0,
                   h_s: float = 0.01, **bench_kw: Any) -> tuple[np.ndarray, np.ndarray]:
    """Hold F, step u up then down; return (u, x) readings with x in m, shapes (2 n,)."""
    return _voltage_sweep(LoadMode.FORCE, force_n, voltages_v, dwell_s, h_s, False, **bench_kw)


def isobaric_sweep(voltage_v: float, forces_n: np.ndarray, dwell_s: float = 3.0,
                   h_s: float = 0.01, **bench_kw: Any) -> tuple[np.ndarray, np.ndarray]:
    """Hold u, step F up then down; return (F set, x) readings with x in m, shapes (2 n,)."""
    b = SingleMuscleBench(**bench_kw)
    b.command_valve(voltage_v)
    b.command_load(LoadMode.FORCE, float(forces_n[0]))
    b.run(3.0, h_s)
    fs = np.concatenate([forces_n, forces_n[::-1]])
    xs = []
    for f in fs:
        b.command_load(LoadMode.FORCE, float(f))
        st = b.run(dwell_s, h_s)
        xs.append(st.measured_angle_rad * b.servo.r)
    return fs, np.array(xs)


def isometric_gain(u: np.ndarray, f: np.ndarray) -> float:
    """Slope dF/du of an up-then-down sweep (first half up), N/V, by the extraction's own
    estimator (hysteresis midline, ``pam_bench.analysis.static.isometric_lines``)."""
    n = len(u) // 2
    direction = np.concatenate([np.zeros(n, dtype=int), np.ones(len(u) - n, dtype=int)])
    line = midline_fit(np.asarray(u), np.asarray(f), direction)
    return line[0] if line is not None else 0.0


def calibration_figures(h_s: float = 0.01, dwell_s: float = 3.0) -> dict[str, float]:
    """The calibration figures of the default bench (SI inputs, paper units in the keys)."""
    volts = np.round(np.arange(0.0, 6.0 + 1e-9, 0.5), 10)
    u0, f0 = isometric_sweep(0.0, volts, dwell_s, h_s)
    u95, f95 = isometric_sweep(0.095, volts, dwell_s, h_s)
    _, x50 = isotonic_sweep(50.0, volts, dwell_s, h_s)
    n = len(volts)
    forces = np.arange(50.0, 950.0 + 1e-9, 50.0)
    hyst = 0.0
    for u in (2.0, 4.0, 6.0):
        _, xb = isobaric_sweep(u, forces, dwell_s, h_s)
        m = len(forces)
        hyst = max(hyst, float(np.max(np.abs(xb[:m] - xb[m:][::-1]))))
    return {
        'isometric_gain_N_per_V_at_0mm': isometric_gain(u0, f0),
        'isometric_gain_N_per_V_at_95mm': isometric_gain(u95, f95),
        'contraction_mm_at_6V_50N': float(x50[n - 1] * 1e3),
        'force_N_at_6V_0mm': float(f0[n - 1]),
        'isobaric_hysteresis_mm_max': hyst * 1e3,
        'exchange_step_s': h_s,
        'dwell_s': dwell_s,
    }
