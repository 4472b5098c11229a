"""Fidelity per scene: what each model option costs and buys, measured on the numpy bench.

For each scene kind the quantity the scene measures is computed with the default models and
with one option changed at a time (valve dynamics order 1 or 0, braid friction off, sensor
noise off, loading-servo dynamics off); the table gives the change of that quantity and the
wall time. A scene keeps an option on when switching it off moves its quantity by more than
its tolerance (0.2 % of the 2 kN full scale for force readings, 0.2 mm for contraction, 3 %
for b, c, d, 2 % of the 5 N m amplitude for the torque), and may drop it otherwise.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from pam_bench.analysis.identify import fit_step
from pam_bench.control.torque_servo import ServoMode, Signal, SignalKind
from pam_bench.models.loading_servo import LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.protocol.schedules import Direction, Reading
from pam_bench.twin.bench import SingleMuscleBench
from pam_bench.twin.protocol_run import run_readings
from pam_bench.twin.servo_bench import run_servo, tracking_metrics

__all__ = ['VARIANTS', 'fidelity_table']

# option -> bench keyword arguments
VARIANTS: dict[str, dict[str, Any]] = {
    'default': {},
    'valve order 1': {'valve': ValveParams(order=1)},
    'valve order 0': {'valve': ValveParams(order=0)},
    'no friction': {'muscle': MuscleParams(hysteresis=False)},
    'no noise': {'load_cell': LoadCellParams(noise=False)},
    'ideal drive': {'servo': LoadingServoParams(dynamics=False)},
}
VOLTS = np.round(np.concatenate([np.arange(0.0, 6.01, 0.5), np.arange(5.5, -0.01, -0.5)]), 6)


def _sweep(kind: str, value: float, **kw: Any) -> np.ndarray:
    """A 0.5 V series as the scene runs it (3 s exchanges, 5 ms sub-steps,
    ``twin.protocol_run``)."""
    run = run_readings(kind, _series(kind, value), 3.0, 3.0, **kw)
    if kind == 'isometric':
        return np.array([p.measurement.force_n for p in run.points])
    return 1e3 * np.array([p.measurement.contraction_m for p in run.points])


def _series(kind: str, value: float) -> list[Reading]:
    mode = LoadMode.POSITION if kind == 'isometric' else LoadMode.FORCE
    n = len(VOLTS) // 2 + 1
    return [Reading(kind, 0, k, Direction.UP if k < n else Direction.DOWN, value, float(u),
                    float(u), mode, value, 3.0) for k, u in enumerate(VOLTS)]


def _step(**kw: Any) -> np.ndarray:
    """004's identification step at 40 mm: 3 s at 1 V, then 1 s at 1 kHz after 5 V."""
    b = SingleMuscleBench(**kw)
    b.command_load(LoadMode.POSITION, 0.04, now=True)
    b.servo.reset(0.04)
    b.command_valve(1.0)
    b.run(3.0, 3.0)
    b.command_valve(5.0)
    b.step(1.0, 0.001)
    f = np.array([m for _, m in b.samples])
    fit = fit_step(f, 0.001, 4.0)
    return np.array([fit.b, fit.c, fit.d])


SCENES = {
    # scene: (quantity, unit, tolerance, function of the bench options)
    'isometric (x = 40 mm, 0.5 V steps, 3 s exchanges)': (
        'readings F', 'N', 4.0, lambda kw: _sweep('isometric', 0.04, **kw)),
    'isotonic (F = 200 N, 0.5 V steps, 3 s exchanges)': (
        'readings x', 'mm', 0.2, lambda kw: _sweep('isotonic', 200.0, **kw)),
    'step response (x = 40 mm, 1 -> 5 V, one 1 s exchange)': (
        'b, c, d', 'relative', 0.03, lambda kw: _step(**kw)),
}


def fidelity_table(inverse: Any = None) -> list[dict[str, Any]]:
    """One row per scene kind and option (module docstring)."""
    rows = []
    for scene, (what, unit, tol, fn) in SCENES.items():
        base = None
        base_wall = 0.0
        for name, kw in VARIANTS.items():
            t0 = time.perf_counter()
            val = fn(kw)
            wall = time.perf_counter() - t0
            if base is None:
                base, base_wall = val, wall
            if unit == 'relative':
                change = float(np.max(np.abs(val / base - 1.0)))
            else:
                change = float(np.max(np.abs(val - base)))
            rows.append({'scene': scene, 'option': name, 'quantity': what, 'unit': unit,
                         'change': change, 'tolerance': tol, 'within': change <= tol,
                         'wall_s': wall, 'speed_up': base_wall / wall if wall else 0.0})
    if inverse is not None:
        sig = Signal(SignalKind.SINE, 5.0, 1.0)
        first: float | None = None
        for name, kw in VARIANTS.items():
            if name == 'ideal drive':          # the servo scenes already hold the angle ideally
                continue
            t0 = time.perf_counter()
            run = run_servo(ServoMode.DYNAMIC, sig, 4.0, inverse=inverse,
                            valve=kw.get('valve'), muscle=kw.get('muscle'),
                            noise='load_cell' not in kw)
            wall = time.perf_counter() - t0
            rms = tracking_metrics(run)['rms_error']
            if first is None:
                first, base_wall = rms, wall
            rows.append({'scene': 'servo_sin_t (numpy twin, 1 ms)', 'option': name,
                         'quantity': 'torque RMS error', 'unit': 'N m',
                         'change': abs(rms - first), 'tolerance': 0.1, 'within':
                         abs(rms - first) <= 0.1, 'wall_s': wall,
                         'speed_up': base_wall / wall if wall else 0.0, 'value': rms})
    return rows

