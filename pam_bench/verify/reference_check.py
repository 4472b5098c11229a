"""Settled readings against the finest exchange step: one series on the numpy bench, and a
whole recorded run checked reading by reading against its numpy twin at 1 ms.

The numpy bench (``SingleMuscleBench``) steps the same models in the same order as the nodes,
and ``twin.protocol_run`` drives it with the sequencer's own state machine, so a series or a
scene it runs at 1 ms exchanges on 1 ms sub-steps is the reference the scenes' long exchanges
and 5 ms sub-steps are measured against (BENCHMARKS.md, 'Exchange step and sub-step against
error', 'The campaign against its numpy twin'). For a recorded run the reference uses the
scene's own model parameters and a noise-free load cell; the recorded readings keep their
sensor noise (load cell 0.2 N RMS, encoder 3 um counts), which is part of the difference
reported.
"""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np

from pam_bench.models.constants import LOAD_CELL_RANGE_N, SUB_STEP_S
from pam_bench.models.coupling import SettleParams
from pam_bench.models.loading_servo import LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.protocol.schedules import Direction, Reading
from pam_bench.twin.protocol_run import run_readings

__all__ = ['FULL_SCALE_N', 'series_readings', 'run_against_twin', 'compare_run']

FULL_SCALE_N = LOAD_CELL_RANGE_N     # load cell range, N
QUIET = LoadCellParams(noise=False)
KINDS = ('isometric', 'isotonic', 'isobaric')


def series_readings(kind: str, value: float, swept: list[float], h_s: float,
                    sub_step_s: float = SUB_STEP_S,
                    models: tuple[ValveParams, MuscleParams, LoadingServoParams] | None = None,
                    settle: SettleParams | None = None) -> tuple[np.ndarray, float, float]:
    """One series of readings (3 s dwell each, after 3 s at the held value) on the numpy
    bench from rest, run by the sequencer's state machine with the nodes' exchange steps
    (``twin.protocol_run``), noise-free sensors.

    Args:
        kind: isometric (x held at ``value`` m, u swept), isotonic (F held at ``value`` N, u
            swept) or isobaric (u held at ``value`` V, F swept).
        value: the held quantity (m, N or V).
        swept: the swept set values in order (V or N), shape (n,).
        h_s: the longest exchange step, s (the devices and the sequencer ask for shorter).
        sub_step_s: sub-step of the coupled muscle and drive, s.
        models: valve, muscle and loading-servo parameters (None: the defaults).
        settle: when a settled muscle is held (None: the muscle node's default).

    Returns:
        (readings: measured force N for isometric, encoder contraction m otherwise, shape
        (n,); exchanges per reading; wall time of the run, s).
    """
    if kind not in KINDS:
        raise ValueError(f'series kind {kind!r}: use one of {", ".join(KINDS)}')
    valve, muscle, servo = models[:3] if models else (ValveParams(), MuscleParams(),
                                                      LoadingServoParams())
    half = len(swept) // 2
    readings = []
    for k, v in enumerate(swept):
        d = Direction.UP if k < half or len(swept) == 1 else Direction.DOWN
        if kind == 'isobaric':
            u, mode, load = value, LoadMode.FORCE, float(v)
        else:
            u, mode = float(v), (LoadMode.POSITION if kind == 'isometric' else LoadMode.FORCE)
            load = value
        readings.append(Reading(kind, 0, k, d, value, float(v), u, mode, load, 3.0))
    run = run_readings(kind, readings, 3.0, h_s, sub_step_s, valve=valve, muscle=muscle,
                       servo=servo, load_cell=QUIET, settle=settle)
    out = [p.measurement.force_n if kind == 'isometric' else p.measurement.contraction_m
           for p in run.points]
    return np.array(out), run.exchanges / len(swept), run.wall_s


def run_against_twin(bag: str | pathlib.Path, scene_name: str, exchange_step_s: float = 0.001,
                     sub_step_s: float = 0.001) -> dict[str, Any]:
    """Every reading and step record of a recorded run against the numpy twin of the same
    scene (``twin.protocol_run``: the sequencer's own state machine on the numpy bench) at
    ``exchange_step_s`` and ``sub_step_s``, sensors noise-free.

    Returns:
        {'protocols': one row per protocol (readings, largest and 99th-percentile difference
        of the read quantity, N or mm, force also in % FS), 'records': largest relative
        difference of b, c, d over the step records (all, and 004's 1 <-> 5 V steps; a
        record whose noise-free reference does not move is counted, not compared), and the
        twin's exchanges and wall time}.

    Raises:
        pam_bench.bags.bagread.BagError: the bag cannot be read.
        ValueError: the bag does not hold the scene's readings in the twin's order.
    """
    from pam_bench.bags.bagread import read_bags
    from pam_bench.config.scene import load_scene
    from pam_bench.twin.protocol_run import run_protocol
    from pam_bench.verify.truth import scene_models
    scene = load_scene(scene_name)
    data = read_bags([bag])
    m = scene_models(scene_name)
    twin = run_protocol(scene.protocol, exchange_step_s, overrides=scene.protocol_overrides,
                        sub_step_s=sub_step_s, valve=m.valve, muscle=m.muscle, servo=m.servo,
                        straight_fibre=m.straight_fibre, load_cell=QUIET)
    return {'scene': scene_name, 'exchange_step_s': exchange_step_s, 'sub_step_s': sub_step_s,
            **compare_run(data, twin), 'twin_exchanges': twin.exchanges,
            'twin_wall_s': twin.wall_s}


def compare_run(data: Any, twin: Any) -> dict[str, Any]:
    """The per-protocol and step-record rows of ``run_against_twin`` for bag data
    (``bags.bagread.BagData``) and a ``twin.protocol_run.TwinRun`` of the same schedule.

    Raises:
        ValueError: the bag does not hold the twin's readings.
    """
    from pam_bench.analysis.identify import fit_step
    rows = []
    for name in dict.fromkeys(p.reading.protocol for p in twin.points):
        mine = [p for p in twin.points if p.reading.protocol == name]
        pts = data.points.get(name)
        if pts is None or len(pts) != len(mine):
            raise ValueError(f'the bag holds {0 if pts is None else len(pts)} readings of '
                             f'{name}, the twin {len(mine)}')
        order = np.lexsort((pts.step, pts.series))
        force = name.startswith(('isometric', 'step_response'))
        rec = (pts.force_n if force else pts.contraction_m)[order]
        ref = np.array([p.measurement.force_n if force else p.measurement.contraction_m
                        for p in mine])
        diff = np.abs(rec - ref) * (1.0 if force else 1e3)
        rows.append({'protocol': name, 'readings': len(mine), 'unit': 'N' if force else 'mm',
                     'max_error': float(diff.max()),
                     'p99_error': float(np.percentile(diff, 99)),
                     'max_error_pct_fs': (float(diff.max() / FULL_SCALE_N * 100) if force
                                          else None)})
    errs, big, flat = [], [], 0
    for a, b in zip(data.records, twin.records, strict=False):
        dv = a.voltage_final_v - a.voltage_initial_v
        fb = fit_step(np.asarray(b.samples), a.sample_period_s, dv)
        if not all(getattr(fb, k) for k in 'bcd'):   # the reference does not move (a step
            flat += 1                                  # below the muscle's first pull): no
            continue                                   # b, c, d to compare against
        fa = fit_step(np.asarray(a.force_n), a.sample_period_s, dv)
        e = max(abs(getattr(fa, k) / getattr(fb, k) - 1.0) for k in 'bcd')
        errs.append(e)
        if abs(abs(dv) - 4.0) < 1e-9:
            big.append(e)
    records = {'records': len(errs), 'flat_references': flat,
               'max_bcd_rel_error': max(errs, default=0.0),
               'max_bcd_rel_error_1_5V': max(big, default=0.0)}
    return {'protocols': rows, 'records': records}
