"""Settled readings against the finest exchange step: one series on the numpy bench, and the
series of a recorded run checked against the same series at a fixed 1 ms exchange.

The numpy bench (``SingleMuscleBench``, chained coupling) steps the same models in the same
order as the nodes, so a series it runs at 1 ms is the reference the scenes' longer exchange
steps are measured against (BENCHMARKS.md, "Exchange step against error"). For a recorded run
the reference uses the scene's own model parameters and a noise-free load cell; the recorded
readings keep their sensor noise (load cell 0.2 N RMS, encoder 3 um counts), which is part of
the difference reported.
"""

from __future__ import annotations

import dataclasses
import pathlib
import time
from typing import Any

import numpy as np

from pam_bench.models.loading_servo import LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.sim.bench import SingleMuscleBench

__all__ = ['FULL_SCALE_N', 'series_readings', 'check_recorded_series']

FULL_SCALE_N = 2000.0          # load cell range, N
QUIET = LoadCellParams(noise=False)
KINDS = ('isometric', 'isotonic', 'isobaric')


def series_readings(kind: str, value: float, swept: list[float], h_s: float,
                    adaptive: bool = False, transient_s: float | None = None,
                    models: tuple[ValveParams, MuscleParams, LoadingServoParams] | None = None
                    ) -> tuple[np.ndarray, float, float]:
    """One series of readings (3 s dwell each) on the numpy bench, from rest.

    Args:
        kind: isometric (x held at ``value`` m, u swept), isotonic (F held at ``value`` N, u
            swept) or isobaric (u held at ``value`` V, F swept).
        value: the held quantity (m, N or V).
        swept: the swept set values in order (V or N), shape (n,).
        h_s: exchange step, s (the longest one with ``adaptive``).
        adaptive: let the devices ask for shorter steps (as the ROS sim clock does).
        transient_s: the devices' transient step, s (None: their defaults).
        models: valve, muscle and loading-servo parameters (None: the defaults).

    Returns:
        (readings: measured force N for isometric, encoder contraction m otherwise, shape
        (n,); exchanges per reading; wall time of the readings, s).
    """
    if kind not in KINDS:
        raise ValueError(f'series kind {kind!r}: use one of {", ".join(KINDS)}')
    valve, muscle, servo = models or (ValveParams(), MuscleParams(), LoadingServoParams())
    if transient_s:
        valve = dataclasses.replace(valve, transient_step_s=transient_s)
        servo = dataclasses.replace(servo, transient_step_s=transient_s)
    b = SingleMuscleBench(valve=valve, muscle=muscle, load_cell=QUIET, servo=servo,
                          coupling='chained')
    if kind == 'isometric':
        b.command_load(LoadMode.POSITION, value)
    elif kind == 'isotonic':
        b.command_load(LoadMode.FORCE, value)
    else:
        b.command_valve(value)
        b.command_load(LoadMode.FORCE, swept[0])
    b.run(3.0, h_s, adaptive)
    b.steps = 0
    out = []
    t0 = time.perf_counter()
    for v in swept:
        if kind == 'isobaric':
            b.command_load(LoadMode.FORCE, v)
        else:
            b.command_valve(v)
        st = b.run(3.0, h_s, adaptive)
        out.append(st.measured_force_n if kind == 'isometric'
                   else st.measured_angle_rad * b.servo.r)
    steps = b.steps if adaptive else len(swept) * round(3.0 / h_s)
    return np.array(out), steps / len(swept), time.perf_counter() - t0


def check_recorded_series(bag: str | pathlib.Path, scene_name: str,
                          cases: list[tuple[str, float]], h_s: float = 0.001
                          ) -> list[dict[str, Any]]:
    """Recorded series against the same series on the numpy bench at ``h_s``.

    Args:
        bag: bag directory of a run of ``scene_name``.
        scene_name: the scene (its model parameters build the reference).
        cases: (protocol name in the bag, held value in SI) of each series to check; the
            protocol's kind is the name up to the first underscore.
        h_s: exchange step of the reference, s.

    Returns:
        One row per case: protocol, held value, readings, largest and RMS difference (N or mm,
        force also in % of the 2 kN full scale), the reading where the largest one sits, the
        largest difference after the series' first reading (the reference starts the series
        from rest, the run from where the previous series left the muscle and its friction)
        and the reference's wall time.

    Raises:
        pam_bench.analysis.bagread.BagError: the bag cannot be read.
        ValueError: a case's series is not in the bag.
    """
    from pam_bench.analysis.bagread import read_bags
    from pam_bench.sim.truth import scene_models
    data = read_bags([bag])
    models = scene_models(scene_name)
    rows = []
    for protocol, held in cases:
        kind = protocol.split('_')[0]
        pts = data.points.get(protocol)
        sel = (np.abs(pts.series_value - held) < 1e-9) if pts is not None else None
        if sel is None or not sel.any():
            raise ValueError(f'series {protocol} at {held:g} is not in {bag}')
        order = np.argsort(pts.step[sel])
        swept = list(pts.set_value[sel][order])
        recorded = (pts.force_n if kind == 'isometric' else pts.contraction_m)[sel][order]
        t0 = time.perf_counter()
        ref, _, _ = series_readings(kind, held, swept, h_s, models=models)
        wall = time.perf_counter() - t0
        scale, unit = (1.0, 'N') if kind == 'isometric' else (1e3, 'mm')
        diff = (recorded - ref) * scale
        k = int(np.argmax(np.abs(diff)))
        rows.append({'protocol': protocol, 'held': held, 'readings': len(swept),
                     'max_error': float(abs(diff[k])), 'rms_error': float(np.sqrt(np.mean(
                         diff ** 2))), 'unit': unit,
                     'max_error_pct_fs': (float(abs(diff[k]) / FULL_SCALE_N * 100)
                                          if kind == 'isometric' else None),
                     'max_error_after_first': float(np.abs(diff[1:]).max(initial=0.0)),
                     'at_set_value': float(swept[k]),
                     'at_direction': 'up' if pts.direction[sel][order][k] == 0 else 'down',
                     'reference_exchange_s': h_s, 'reference_wall_s': wall})
    return rows
