"""Study ``calibrate_nodes``: the bag calibration's round trip through the ROS nodes.

One parameter set is drawn as in study ``calibrate`` (the same seed, so its first set);
campaign_quick runs through the nodes composed in one process with that set as a parameter
overlay (``pam-bench run --params``), the load cell's noise on, as a lab's recording would
be; ``pam-bench calibrate`` fits ``FREE_BAGS`` from the bench's defaults to that bag; the
fitted overlay runs campaign_quick again, and its readings are compared reading by reading
with the original bag (``verify.wallclock.compare_readings``: RMS and largest difference in N
and mm). Reported: each parameter's recovery error and whether the fit identified it, the
RMS per protocol before and after the fit, the fit time and both runs' wall time.
"""

from __future__ import annotations

import dataclasses
import pathlib
import shutil
import time
from typing import Any

import numpy as np
import yaml

from benchmarks.calibrate import draw_parameters, recovery_errors
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.fit.calibrate_bags import overlay_of

__all__ = ['STUDY', 'measure_nodes_round_trip', 'calibrate_nodes_section',
           'calibrate_nodes_results']

def _run(overlay: dict[str, Any], out: pathlib.Path, name: str) -> tuple[pathlib.Path, float]:
    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import apply_overlay, load_scene
    from pam_bench.vocabulary.run import Layout, RunOptions
    path = out / f'{name}.yaml'
    path.write_text(yaml.safe_dump(overlay, sort_keys=False), encoding='utf-8')
    scene = load_scene('campaign_quick')
    apply_overlay(scene, path)
    bag = out / name
    shutil.rmtree(bag, ignore_errors=True)
    t0 = time.perf_counter()
    res = run_scene(scene, str(bag), RunOptions(layout=Layout.COMPOSED, quiet=True))
    if res.code != 0:
        raise RuntimeError(f'campaign_quick with {name} ended with code {res.code}')
    return bag, time.perf_counter() - t0


def measure_nodes_round_trip(out: pathlib.Path) -> dict[str, Any]:
    """Run the round trip (module docstring) into ``out``; return its figures."""
    from pam_bench.bags.bagread import read_bags
    from pam_bench.fit.calibrate_bags import calibrate_bags, observations_from_bags
    from pam_bench.verify.wallclock import compare_readings
    out.mkdir(parents=True, exist_ok=True)
    valve, muscle = draw_parameters(np.random.default_rng(2026))
    print('  through the nodes: the drawn bench ...', flush=True)
    original, run_s = _run(overlay_of(valve, muscle), out, 'drawn')
    obs = observations_from_bags(read_bags([str(original)]))
    print(f'  fitting {len(obs.readings)} readings and {len(obs.records)} step records ...',
          flush=True)
    res = calibrate_bags(obs)
    print('  through the nodes: the calibrated bench ...', flush=True)
    again, rerun_s = _run(overlay_of(res['valve'], res['muscle']), out, 'calibrated')
    diff = compare_readings(original, again)
    fitted = compare_readings(original, again, skip=res['left_out'])
    return {'errors': recovery_errors(res['values'], valve, muscle), 'flags': res['flags'],
            'fit_s': res['fit_s'],
            'evaluations': res['evaluations'], 'rms_before': res['rms_before'],
            'rms_after': res['rms_after'], 'run_s': run_s, 'rerun_s': rerun_s,
            'readings': dataclasses.asdict(diff), 'fitted_readings': dataclasses.asdict(fitted),
            'left_out': [list(r) for r in res['left_out']]}


def calibrate_nodes_section(r: dict[str, Any]) -> list[str]:
    """Recovery per parameter and the rerun's readings against the original bag."""
    c = r['calibrate_nodes']
    d = c['readings']
    rows = [(n, '-' if e is None else f'{e * 100:+.2f} %',
             'no' if n in c['flags'] else 'yes') for n, e in c['errors'].items()]
    lines = table(['parameter', 'recovery error', 'identified'], rows)
    kinds = ', '.join(f"{k} {c['rms_before'][k]:.2f} -> {v:.2f}"
                      for k, v in c['rms_after'].items())
    lines += ['', f"RMS per protocol before -> after the fit (N; mm for isotonic and isobaric): "
              f"{kinds}. Fit: {c['evaluations']} evaluations in {c['fit_s']:.0f} s; the runs "
              f"took {c['run_s']:.0f} s and {c['rerun_s']:.0f} s.", '',
              f"The calibrated bench against the original bag, {d['matched']} readings: "
              f"force RMS {d['rms_force_n']:.2f} N (largest {d['max_force_n']:.2f} N), "
              f"contraction RMS {d['rms_contraction_m'] * 1e3:.3f} mm (largest "
              f"{d['max_contraction_m'] * 1e3:.3f} mm); goal 20 N (1 % FS) and 0.5 mm."]
    f = c.get('fitted_readings')
    if f and c.get('left_out'):
        which = ', '.join(f'{k} {u:g} V {h:g} N'
                          for k, u, h in dict.fromkeys(map(tuple, c['left_out'])))
        lines += ['', f"Without the readings the fit leaves out ({which}: a friction loop "
                  f"wider than 8 mm, where the muscle stops is decided by the drive's "
                  f"transient), {f['matched']} readings: force RMS {f['rms_force_n']:.2f} N "
                  f"(largest {f['max_force_n']:.2f} N), contraction RMS "
                  f"{f['rms_contraction_m'] * 1e3:.3f} mm (largest "
                  f"{f['max_contraction_m'] * 1e3:.3f} mm)."]
    return lines


def calibrate_nodes_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result row: the recalibrated bench against the original bag."""
    c = r.get('calibrate_nodes')
    if not c:
        return []
    d = c['readings']
    rows: list[Row] = [('bag calibration through the nodes (campaign_quick): the calibrated bench '
             'against the original readings, RMS', '<= 20 N and 0.5 mm',
             f"{d['rms_force_n']:.2f} N, {d['rms_contraction_m'] * 1e3:.3f} mm "
             f"(fit {c['fit_s']:.0f} s)", commit)]
    f = c.get('fitted_readings')
    if f and c.get('left_out'):
        rows.append(('the same without the readings the fit leaves out (friction loop wider '
                     'than 8 mm)', '<= 20 N and 0.5 mm',
                     f"{f['rms_force_n']:.2f} N, {f['rms_contraction_m'] * 1e3:.3f} mm "
                     f"({f['matched']} readings)", commit))
    return rows


STUDY = Study(
    'calibrate_nodes', 'the calibration round trip through the nodes (a bag, its overlay, a '
    'rerun)',
    lambda quick, out, scenes: {'calibrate_nodes': measure_nodes_round_trip(
        out / 'calibrate_nodes')},
    (('calibrate_nodes', lambda r, root: calibrate_nodes_section(r)),),
    lambda r: calibrate_nodes_results(r, commit_of(r, 'calibrate_nodes')))
"""The calibration round trip through the nodes (bench.json ``calibrate_nodes``)."""
