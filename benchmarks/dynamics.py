"""Study ``dynamics``: why the dynamic inverse model loses to the static one on this bench
(issue 31's decomposition of 004 section 3.1, Figs. 17-19).

The inverse models alone (no PID) drive muscle 1 at a held contraction to F* = 50 sin t +
400 N (``force_verify_20mm``, ``force_verify_50mm``) on the servo twin (``twin.servo_bench``,
the nodes' models exchange for exchange). For every bench variant the inverse model is
identified again, as ``make inverse-model`` does, from the ``identification`` scene run on
the twin (``twin.protocol_run``) and read by the extraction's own estimators, so a variant is
never judged with a model identified on another bench. Variants: the bench as it is; the braid
friction off (``muscle_1.muscle.hysteresis``); the valve at a fixed volume
(``valve_1.valve.volume_scaling``: its natural frequency no longer moves with the muscle's
volume); both; and a sharp or narrow contact band (``muscle_1.muscle.threshold_width_pa``),
which makes the force nearly linear in the voltage above the threshold, the condition 004
states for its muscle before its Eq. 2.

The dynamic inverse (004 Eq. 5 as ``control.inverse`` codes it) is

    u = u0 + (F*'' + b F*' + c (F* - F_a0(x))) / d
      = [u0 + c (F* - F_a0) / d]  +  [(F*'' + b F*') / d]
        linearised static part        dynamic part

and the static inverse u_s = (F* - F0(x)) / k(x) (the isometric midline). Along the set
signal, at the held x, the study splits the dynamic model's voltage into those two parts and
reports the RMS of the dynamic part, and the RMS gap between the linearised static part and the
static inverse, in V and, times the isometric gain k(x), in N: the force the linearisation
around (u0, F_a0) misplaces before any dynamics. It also reports how well the polynomials in x
carry the per-record step fits (b, c, d relative residuals), and each model's RMS tracking
error when it drives the bench alone.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table

__all__ = ['STUDY', 'VARIANTS', 'SCENES', 'identify', 'voltage_split', 'measure']

SCENES = ('force_verify_20mm', 'force_verify_50mm')
VARIANTS: tuple[tuple[str, dict[str, Any]], ...] = (
    ('bench', {}),
    ('friction off', {'muscle_1.muscle.hysteresis': False}),
    ('fixed valve volume', {'valve_1.valve.volume_scaling': False}),
    ('friction off, fixed volume', {'muscle_1.muscle.hysteresis': False,
                                    'valve_1.valve.volume_scaling': False}),
    ('sharp contact band', {'muscle_1.muscle.threshold_width_pa': 0.0}),
    ('narrow contact band (10 kPa)', {'muscle_1.muscle.threshold_width_pa': 1.0e4}),
)
"""(name, settings by path over the scenes): the bench variants the decomposition runs."""


def _scene(name: str, values: dict[str, Any]) -> Any:
    from pam_bench.config.scene import load_scene
    scene = load_scene(name)
    for path, value in values.items():
        scene.set(path, value)
    return scene


def identify(values: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
    """The inverse model of the bench with ``values`` set, identified from the
    ``identification`` scene on the twin.

    Returns:
        (InverseModel, the step fits' summary: per-record fits and polynomials).

    Raises:
        RuntimeError: the run holds too little to build a model.
    """
    from pam_bench.analysis.extract import inverse_model_of, step_summary
    from pam_bench.control.inverse import InverseModel
    from pam_bench.twin.protocol_run import bag_data_of, run_scene
    data = bag_data_of(run_scene(_scene('identification', values), seed=0))
    step = step_summary(data.records)
    mapping = inverse_model_of(data, step)
    if mapping is None:
        raise RuntimeError('the identification run holds no step records or isometric points')
    return InverseModel.from_dict(mapping), dict(step)


def fit_residuals(step: dict[str, Any], x_mm: float) -> dict[str, float]:
    """How far the 5th-degree polynomials in x sit from the per-record fits of b, c, d: RMS
    relative residual over the 'up' records, and the relative gap at ``x_mm`` (the nearest
    record)."""
    ups = [f for f in step['fits'] if f['direction'] == 'up']
    out: dict[str, float] = {}
    for key in ('b', 'c', 'd'):
        p = step['polynomials'][key]
        coef = p['coefficients_low_to_high']

        def poly(x: float, coef: list[float] = coef, p: dict[str, Any] = p) -> float:
            z = (x - p['x_mid_mm']) / p['x_half_range_mm'] if p['x_half_range_mm'] else 0.0
            return float(np.polynomial.polynomial.polyval(min(max(z, -1.0), 1.0), coef))
        rel = [(poly(f['x_mm']) - f[key]) / f[key] for f in ups if f[key]]
        out[f'{key}_rms_rel'] = float(np.sqrt(np.mean(np.square(rel)))) if rel else math.nan
        near = min(ups, key=lambda f: abs(f['x_mm'] - x_mm)) if ups else None
        out[f'{key}_at_x_rel'] = (poly(near['x_mm']) - near[key]) / near[key] \
            if near and near[key] else math.nan
    return out


def voltage_split(model: Any, signal: Any, x_m: float, duration_s: float, h_s: float = 0.01,
                  settled_force: Callable[[float], float] | None = None) -> dict[str, float]:
    """The dynamic inverse's voltage along the set signal at held ``x_m``, split (module
    docstring): RMS of its dynamic part (V), RMS gap of its linearised static part to the
    static inverse (V, and N through k(x)), the static inverse's mean voltage (V).

    ``settled_force(u)``: the force (N) the bench settles to at voltage u and the held x,
    friction-free (the backbone at the valve's steady pressure). With it, the RMS of
    settled_force(u) - F* for the linearised static part and for the static inverse: the
    error each model makes before any dynamics or friction (``settled_error_*_n``).
    """
    t = np.arange(0.0, duration_s, h_s)
    f, df, ddf = np.array([signal.value_and_rates(ti) for ti in t]).T
    d = model.d(x_m)
    lin = np.clip(model.u0_v + model.c(x_m) * (f - model.f_a0(x_m)) / d, model.u_min_v,
                  model.u_max_v)
    rate = (ddf + model.b(x_m) * df) / d
    static = np.array([model.static_voltage(fi, x_m) for fi in f])
    gap = lin - static
    out = {'u_dynamic_part_rms_v': float(np.sqrt(np.mean(rate ** 2))),
           'u_static_gap_rms_v': float(np.sqrt(np.mean(gap ** 2))),
           'u_static_gap_mean_v': float(np.mean(gap)),
           'force_gap_rms_n': float(np.sqrt(np.mean(gap ** 2))) * model.k(x_m),
           'u_static_mean_v': float(np.mean(static)),
           'chord_gain_n_per_v': d / model.c(x_m), 'isometric_gain_n_per_v': model.k(x_m)}
    if settled_force is not None:
        for key, u in (('dynamic', lin), ('static', static)):
            err = np.array([settled_force(ui) for ui in u]) - f
            out[f'settled_error_{key}_n'] = float(np.sqrt(np.mean(err ** 2)))
            out[f'settled_bias_{key}_n'] = float(np.mean(err))
    return out


def _tracking(scene_name: str, values: dict[str, Any], model: Any, mode: Any,
              duration_s: float | None, slower: float = 1.0) -> float:
    """RMS tracking error (N) of ``model`` alone on the scene; ``slower``: the sine's
    frequency divided by this, the run as many times longer (quasi-static at 10)."""
    from pam_bench.twin.servo_bench import run_servo, tracking_metrics
    from pam_bench.twin.servo_setup import scene_servo_setup
    scene = _scene(scene_name, values)
    setup = scene_servo_setup(scene)
    st = scene.settings()
    sig = dataclasses.replace(setup['signal'],
                              omega_rad_s=setup['signal'].omega_rad_s / slower)
    run = run_servo(mode, sig, (duration_s or scene.duration_s) * slower, setup['angle_rad'],
                    scene.exchange_step_s, model, setup['muscles'], setup['params'],
                    st['valve_1'].valve, st['muscle_1'].muscle)
    return float(tracking_metrics(run, settle_s=slower)['rms_error'])


def measure(quick: bool, out: Any, scenes: list[str] | None) -> dict[str, Any]:
    """Every variant: identify, split the voltage, run both inverse models alone."""
    from pam_bench.config.paths import config_dir
    from pam_bench.control.inverse import InverseModel
    from pam_bench.control.torque_servo import ServoMode
    from pam_bench.models.muscle import MuscleModel
    from pam_bench.models.valve import ValveModel
    from pam_bench.twin.servo_setup import scene_servo_setup
    duration = 3.0 if quick else None
    rows = []
    shipped = InverseModel.load(config_dir() / 'inverse_model.yaml')
    for variant, values in VARIANTS[:1] if quick else VARIANTS:
        print(f'  dynamics: {variant}: identify ...', flush=True)
        model, step = identify(values)
        models = [('identified on the twin', model)]
        if not values:
            models.append(('config/inverse_model.yaml', shipped))
        for scene_name in scenes or SCENES:
            scene = _scene(scene_name, values)
            setup = scene_servo_setup(scene)
            st = scene.settings()
            x_m = float(st['loading_servo'].initial_setpoint)
            muscle, valve = MuscleModel(st['muscle_1'].muscle), ValveModel(st['valve_1'].valve)

            def settled(u: float, muscle: Any = muscle, valve: Any = valve, x_m: float = x_m
                        ) -> float:
                return float(muscle.backbone(valve.steady_pressure(u), x_m))
            for source, m in models:
                row: dict[str, Any] = {'variant': variant, 'scene': scene_name, 'model': source,
                                       'x_mm': x_m * 1e3}
                row.update(voltage_split(m, setup['signal'], x_m, 2 * math.pi,
                                         settled_force=settled))
                row.update(fit_residuals(step, x_m * 1e3))
                for mode in (ServoMode.DYNAMIC_ONLY, ServoMode.STATIC_ONLY):
                    row[f'rms_{mode.value}_n'] = _tracking(scene_name, values, m, mode,
                                                           duration)
                    row[f'rms_{mode.value}_slow_n'] = _tracking(scene_name, values, m, mode,
                                                                duration, slower=10.0)
                rows.append(row)
    return {'dynamics': {'rows': rows, 'amplitude_n': 50.0}}


def section(r: dict[str, Any], root: Any) -> list[str]:
    """One row per variant, scene and model."""
    rows = r['dynamics']['rows']
    head = ['variant', 'scene', 'inverse model', 'dynamic alone, RMS N (10x slower)',
            'static alone, RMS N (10x slower)', 'settled error, dynamic / static model, RMS N '
            '(bias)', 'dynamic part of u, RMS V', 'linearised static part - static inverse, '
            'RMS V (N)', 'chord gain d/c against k(x), N/V',
            'polynomials against record fits b, c, d (RMS rel.)']
    return table(head, [(
        x['variant'], x['scene'], x['model'],
        f"{x['rms_dynamic_inverse_n']:.2f} ({x['rms_dynamic_inverse_slow_n']:.2f})",
        f"{x['rms_static_inverse_n']:.2f} ({x['rms_static_inverse_slow_n']:.2f})",
        f"{x['settled_error_dynamic_n']:.2f} ({x['settled_bias_dynamic_n']:+.2f}) / "
        f"{x['settled_error_static_n']:.2f} ({x['settled_bias_static_n']:+.2f})",
        f"{x['u_dynamic_part_rms_v']:.4f}",
        f"{x['u_static_gap_rms_v']:.3f} ({x['force_gap_rms_n']:.1f})",
        f"{x['chord_gain_n_per_v']:.1f} / {x['isometric_gain_n_per_v']:.1f}",
        f"{x['b_rms_rel']:.3f}, {x['c_rms_rel']:.3f}, {x['d_rms_rel']:.3f}")
        for x in rows])


def results(r: dict[str, Any]) -> list[Row]:
    """Dynamic against static inverse alone on the bench as it is."""
    d = r.get('dynamics')
    if not d:
        return []
    out: list[Row] = []
    for x in d['rows']:
        if x['variant'] == 'bench' and x['model'] == 'identified on the twin':
            out.append((f"{x['scene']}: inverse model alone, dynamic against static (twin)",
                        'dynamic < static (004 section 3.1); < 2.5 N',
                        f"{x['rms_dynamic_inverse_n']:.2f} N against "
                        f"{x['rms_static_inverse_n']:.2f} N",
                        commit_of(r, 'dynamics')))
    return out


STUDY = Study('dynamics', "004's dynamic against static inverse model: the error decomposed",
              measure, (('dynamics', section),), results)
"""The inverse models' decomposition (bench.json ``dynamics``)."""
