"""`pam-bench truth SCENE`: what the simulated bench's own parameters imply for the figures
`pam-bench extract` reports, in the same keys as summary.json.

The scene's protocol is settled reading by reading on the quasi-static bench
(``pam_bench.twin.quasistatic``) with the scene's model parameters, and the readings go through
the same estimators as the recorded ones (``pam_bench.analysis.static``):

- gains (isometric N/V, isotonic mm/V): on the friction-free backbone (hysteresis off), i.e.
  the muscle law g(x) (p - p_th) - k_bl x of the muscle module seen through the valve gain k_v
  and the belt stretch F / k_b. This is what an estimator that cancels the friction must find.
- isobaric hysteresis: with the Maxwell-slip friction on, along the protocol's path.
- step response (004 Eq. 2, F'' + b F' + c F = d u around the working point): b = 2 zeta w(V),
  c = w(V)^2 of the valve's pressure loop at the chamber volume of x (valve module; F is
  affine in p at held x, so the force inherits the pressure dynamics), d = c dF/du with dF/du
  the settled force change of the step divided by its voltage step (friction on, path as in the
  protocol: settle at u0, step to u1), F_a0 the settled force at u0.

With ``reference`` the scene is also run noise-free on the numpy twin (``twin.protocol_run``: every
device's dynamics, the drive, the braid friction along the protocol's real path) and its
readings and records go through the same estimators: ``isometric.reference_series``,
``isotonic.reference_gain_mm_per_V``, ``isobaric.reference_hysteresis_mm_max`` and
``step_response.reference_fits``. The parameter figures above are what an estimator that
cancelled the friction would find; the reference is what this bench, measured without noise,
gives to the same estimators, so an extraction's difference from it is the measurement's own
(sensor noise, quantisation, fit), and the difference between the two is the estimators' bias
on a bench with braid friction (BENCHMARKS.md, 'Extraction against
`pam-bench truth`').
"""

from __future__ import annotations

import dataclasses
from collections import defaultdict
from typing import Any, NamedTuple, TypeVar

import numpy as np

from pam_bench.analysis.extract import coefficient_polynomials
from pam_bench.analysis.identify import fit_step
from pam_bench.analysis.static import gain_summary
from pam_bench.analysis.summary import Summary
from pam_bench.bags.bagread import Points
from pam_bench.config.protocols import protocol_schedule
from pam_bench.config.scene import load_scene
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveParams
from pam_bench.protocol.schedules import Reading
from pam_bench.twin.quasistatic import QuasiStaticBench, SettledReading

__all__ = ['truth_summary', 'scene_schedule', 'scene_models', 'compare']


def scene_models(scene_name: str) -> SceneModels:
    """Model parameters of the scene's valve_1, muscle_1 (both laws) and loading servo, from
    the scene's settings (``config.scene.Scene.settings``)."""
    st = load_scene(scene_name).settings()
    return SceneModels(st['valve_1'].valve, st['muscle_1'].muscle, st['loading_servo'].servo,
                       st['muscle_1'].straight_fibre)


class SceneModels(NamedTuple):
    """The model parameters a scene's single-muscle bench runs with."""

    valve: ValveParams
    muscle: MuscleParams
    servo: LoadingServoParams
    straight_fibre: StraightFibreParams


def scene_schedule(scene_name: str) -> list[Reading]:
    """Readings of the scene's protocol (config/protocols.yaml + the scene's overrides)."""
    scene = load_scene(scene_name)
    return protocol_schedule(scene.protocol, scene.protocol_overrides)[0]


def _points(rows: list[tuple[Reading, SettledReading]]) -> dict[str, Points]:
    by: dict[str, list[tuple[Reading, SettledReading]]] = defaultdict(list)
    for r, s in rows:
        if r.record_s == 0.0 and r.ramp_from_v is None:
            by[r.protocol].append((r, s))
    out = {}
    for name, items in by.items():
        def col(f: Any, items: list = items) -> np.ndarray:
            return np.array([f(r, s) for r, s in items])
        out[name] = Points(name, col(lambda r, s: 0.0), col(lambda r, s: r.series),
                           col(lambda r, s: r.step), col(lambda r, s: int(r.direction)),
                           col(lambda r, s: r.series_value), col(lambda r, s: r.set_value),
                           col(lambda r, s: s.voltage_v), col(lambda r, s: s.force_n),
                           col(lambda r, s: s.contraction_m), col(lambda r, s: s.pressure_pa))
    return out


def _step_truth(bench: QuasiStaticBench, readings: list[Reading]) -> list[dict[str, Any]]:
    """Parameter fits of every step reading; see the module docstring."""
    fits = []
    for r in readings:
        if r.record_s <= 0.0 or r.pre_voltage_v is None:
            continue
        f0, gain = bench.dc_gain(r.load_value, r.pre_voltage_v, r.voltage_v)
        b, c = bench.pressure_dynamics(bench.x_t)
        fits.append({**_step_head(r), 'b': b, 'c': c, 'd': c * gain, 'F_a0_N': f0,
                     'rms_error_N': 0.0, 'delay_samples': 0})
    return fits


def _step_head(r: Reading) -> dict[str, Any]:
    return {'x_mm': r.load_value * 1e3, 'direction': 'up' if r.direction == 0 else 'down',
            'u0_V': r.pre_voltage_v, 'u1_V': r.voltage_v}


def _reference(scene_name: str) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """(gain summary, step fits) of the scene run noise-free on the numpy twin."""
    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.twin.protocol_run import run_protocol
    scene = load_scene(scene_name)
    m = scene_models(scene_name)
    run = run_protocol(scene.protocol, scene.exchange_step_s,
                       overrides=scene.protocol_overrides, sub_step_s=scene.sub_step_s,
                       valve=m.valve, muscle=m.muscle, servo=m.servo,
                       straight_fibre=m.straight_fibre, load_cell=LoadCellParams(noise=False))
    rows = [(p.reading, SettledReading(p.voltage_v, p.measurement.pressure_pa,
                                       p.measurement.force_n, p.measurement.contraction_m,
                                       p.measurement.contraction_m)) for p in run.points]
    fits = []
    for rec in run.records:
        r = rec.reading
        fit = fit_step(np.asarray(rec.samples), r.sample_period_s,
                       r.voltage_v - (r.pre_voltage_v or 0.0))
        fits.append({**_step_head(r), 'b': fit.b, 'c': fit.c, 'd': fit.d, 'F_a0_N': fit.f_a0_n,
                     'rms_error_N': fit.rms_error_n, 'delay_samples': fit.delay_samples})
    return dict(gain_summary(_points(rows))), fits


def truth_summary(scene_name: str, reference: bool = True) -> dict[str, Any]:
    """summary.json-shaped figures the scene's parameters imply (see the module docstring)."""
    m = scene_models(scene_name)
    readings = scene_schedule(scene_name)
    backbone = QuasiStaticBench(m.valve, _without_friction(m.muscle), m.servo,
                                straight_fibre=_without_friction(m.straight_fibre))
    summary: dict[str, Any] = dict(gain_summary(_points([(r, backbone.settle(r))
                                                          for r in readings])))
    summary.pop('isobaric', None)
    with_friction = QuasiStaticBench(m.valve, m.muscle, m.servo,
                                     straight_fibre=m.straight_fibre)
    rows = [(r, with_friction.settle(r)) for r in readings if r.record_s == 0.0]
    hyst = gain_summary({k: v for k, v in _points(rows).items() if k.startswith('isobaric')})
    summary.update(hyst)
    fits = _step_truth(QuasiStaticBench(m.valve, m.muscle, m.servo,
                                        straight_fibre=m.straight_fibre), readings)
    if fits:
        summary['step_response'] = {'fits': fits, 'polynomials': coefficient_polynomials(fits)}
    if reference:
        gains, ref = _reference(scene_name)
        for kind, key, out in (('isometric', 'series', 'reference_series'),
                               ('isotonic', 'gain_mm_per_V', 'reference_gain_mm_per_V'),
                               ('isobaric', 'hysteresis_mm_max', 'reference_hysteresis_mm_max')):
            if kind in gains and kind in summary:
                summary[kind][out] = gains[kind][key]
        if ref and fits:
            summary['step_response']['reference_fits'] = ref
            summary['step_response']['reference_polynomials'] = coefficient_polynomials(ref)
    summary['scene'] = scene_name
    summary['muscle'] = {'kind': m.muscle.kind, **(
        {'segments': m.straight_fibre.segments} if m.muscle.kind == 'straight_fibre' else {})}
    summary['basis'] = ('parameters of the scene: gains on the friction-free backbone, '
                        'hysteresis and step gains with the braid friction, b and c from the '
                        'valve pressure loop at the chamber volume of x; reference_*: the '
                        'scene run noise-free on the numpy twin through the same estimators')
    return summary


P = TypeVar('P', MuscleParams, StraightFibreParams)


def _without_friction(params: P) -> P:
    return dataclasses.replace(params, hysteresis=False)


def _rel(measured: float, true: float) -> float:
    return (measured - true) / true if true else float('inf')


def compare(truth: dict[str, Any], summary: Summary) -> dict[str, Any]:
    """Relative errors (measured - truth) / truth of an extraction against the truth, per
    quantity both hold: isometric gain per series, isotonic gain max and min, step-response
    b, c, d per record; against the parameter figures and, where the truth holds them, the
    noise-free reference (``*_reference`` keys, ``step_reference_fits``)."""
    out: dict[str, Any] = {}
    iso_t, iso_m = truth.get('isometric', {}), summary.get('isometric', {})
    for key, name in (('series', 'isometric_gain'), ('reference_series',
                                                     'isometric_gain_reference')):
        if key in iso_t and 'series' in iso_m:
            ref = {round(s['x_mm'], 6): s['gain_N_per_V'] for s in iso_t[key]}
            out[name] = [{'x_mm': s['x_mm'], 'measured': s['gain_N_per_V'],
                          'truth': ref[round(s['x_mm'], 6)],
                          'rel_error': _rel(s['gain_N_per_V'], ref[round(s['x_mm'], 6)])}
                         for s in iso_m['series'] if round(s['x_mm'], 6) in ref]
    ton_t, ton_m = truth.get('isotonic', {}), summary.get('isotonic', {})
    for key, name in (('gain_mm_per_V', 'isotonic_gain'),
                      ('reference_gain_mm_per_V', 'isotonic_gain_reference')):
        if key in ton_t and 'gain_mm_per_V' in ton_m:
            t, m = ton_t[key], ton_m['gain_mm_per_V']
            out[name] = {k: {'measured': m[k], 'truth': t[k], 'rel_error': _rel(m[k], t[k])}
                         for k in ('max', 'min')}
    bar_t, bar_m = truth.get('isobaric', {}), summary.get('isobaric', {})
    for key, name in (('hysteresis_mm_max', 'isobaric_hysteresis'),
                      ('reference_hysteresis_mm_max', 'isobaric_hysteresis_reference')):
        if key in bar_t and 'hysteresis_mm_max' in bar_m:
            out[name] = {'measured': bar_m['hysteresis_mm_max'], 'truth': bar_t[key],
                         'rel_error': _rel(bar_m['hysteresis_mm_max'], bar_t[key])}
    if 'step_response' in truth and 'step_response' in summary:
        for key in ('fits', 'reference_fits'):
            if key not in truth['step_response']:
                continue
            ref = {(round(f['x_mm'], 6), f['direction'], round(f['u1_V'], 6)): f
                   for f in truth['step_response'][key]}
            rows = []
            for f in summary['step_response']['fits']:
                t = ref.get((round(f['x_mm'], 6), f['direction'], round(f['u1_V'], 6)))
                if t is not None:
                    rows.append({'x_mm': f['x_mm'], 'direction': f['direction'],
                                 'u0_V': f['u0_V'], 'u1_V': f['u1_V'],
                                 **{f'{c}_rel_error': _rel(f[c], t[c]) for c in ('b', 'c', 'd')}})
            out[f'step_{key}'] = rows
    return out
