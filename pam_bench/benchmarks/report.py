"""BENCHMARKS.md from the measured data (bench.json): one renderer, one table helper.

The report opens with the key results (each figure, its goal, the measured value and the
commit it was measured at), then one section per study: its title and method from
``methods.yaml`` (prose, no figures) and its table from the data. The hand-written long runs
(``docs/long_runs.md``, runs too long for every `pam-bench bench`) are included whole at the
end. ``pam-bench bench --render`` renders again from an existing bench.json.
"""

from __future__ import annotations

import functools
import pathlib
from collections.abc import Callable, Iterable, Sequence
from typing import Any

import yaml

from pam_bench.benchmarks.calibrate import calibrate_results, calibrate_section
from pam_bench.benchmarks.calibrate_nodes import calibrate_nodes_results, calibrate_nodes_section
from pam_bench.benchmarks.faults import faults_results, faults_section
from pam_bench.benchmarks.straight_fibre import straight_fibre_results, straight_fibre_section
from pam_bench.benchmarks.wallclock import wallclock_results, wallclock_section

__all__ = ['table', 'key_results', 'render', 'methods', 'LONG_RUNS']

LONG_RUNS = pathlib.Path('docs') / 'long_runs.md'
Row = Sequence[Any]


def table(headers: Sequence[str], rows: Iterable[Row]) -> list[str]:
    """A Markdown table: one line per row, cells as given (strings or numbers)."""
    out = ['| ' + ' | '.join(headers) + ' |', '|' + '---|' * len(headers)]
    out += ['| ' + ' | '.join(str(c) for c in row) + ' |' for row in rows]
    return out


@functools.lru_cache(maxsize=1)
def methods() -> dict[str, dict[str, str]]:
    """Section key -> {'title', 'method'} from methods.yaml."""
    path = pathlib.Path(__file__).with_name('methods.yaml')
    return yaml.safe_load(path.read_text(encoding='utf-8'))


def _pct(x: float | None, digits: int = 3) -> str:
    return '' if x is None else f'{x:.{digits}f}'


def _campaign_max(r: dict[str, Any], unit: str) -> tuple[float, float | None] | None:
    """Largest reading difference of the campaign against its 1 ms twin in ``unit``."""
    cmp = r.get('campaign')
    if not cmp:
        return None
    rows = [row for row in cmp['twin_1ms']['protocols'] if row['unit'] == unit]
    if not rows:
        return None
    worst = max(rows, key=lambda row: row['max_error'])
    return worst['max_error'], worst['max_error_pct_fs']


def commit_of(r: dict[str, Any], key: str) -> str:
    """The commit the figures under ``key`` were measured at (``--only`` reruns some)."""
    return str(r.get('measured', {}).get(key, {}).get('commit', r['commit']))


def _layout_row(r: dict[str, Any], scene: str, layout: str) -> dict[str, Any] | None:
    """The layouts study's row of ``scene`` in ``layout``, if it was measured."""
    for row in r.get('layouts', {}).get('rows', []):
        if row['scene'] == scene and row['layout'] == layout:
            return row
    return None


def _layout_results(r: dict[str, Any]) -> list[Row]:
    if not r.get('layouts'):
        return []
    commit = f"`{commit_of(r, 'layouts')}`"
    pp = r['layouts']['pingpong_round_trips_per_s']
    rows: list[Row] = []
    for layout, goal in (('one process', '>= 1x real time'),
                         ('separate processes', '>= 0.3x real time')):
        row = _layout_row(r, 'servo_sin_t', layout)
        if row:
            rms = (f", torque RMS {row['torque_rms_error_nm']:.4f} N m"
                   if 'torque_rms_error_nm' in row else '')
            rows.append((f'`servo_sin_t` (8 s, 1 ms exchanges), {layout}', goal,
                         f"{row['real_time_factor']:.2f}x ({row['lockstep_rate_steps_per_s']:.0f}"
                         f' exchanges/s{rms})', commit))
    row = _layout_row(r, 'campaign_quick', 'one process')
    if row:
        rows.append(('`campaign_quick` wall time with start-up, one process', '<= 6 s',
                     f"{row['wall_s_total']:.1f} s ({row['real_time_factor']:.0f}x in "
                     'lock-step)', commit))
    row = _layout_row(r, 'campaign', 'one process')
    if row:
        rows.append(('full `campaign` lock-step, one process', '<= 150 s (>= 146x)',
                     f"{row['wall_s_lockstep']:.0f} s ({row['real_time_factor']:.0f}x)",
                     commit))
    row = _layout_row(r, 'demo', 'separate processes')
    if row:
        rows.append(('demo lock-step against the ping-pong floor, separate processes',
                     '>= 0.3', f"{row['lockstep_rate_steps_per_s'] / pp:.3f} "
                     f"({row['lockstep_rate_steps_per_s']:.0f} exchanges/s, {pp:.0f} round "
                     'trips/s)', commit))
    fan = r['layouts'].get('fanout_exchanges_per_s', {})
    for scene, n in (('demo', '7'), ('servo_sin_t', '10')):
        row = _layout_row(r, scene, 'separate processes')
        if row and n in fan:
            rows.append((f'lock-step with no work, {n} separate-process participants (the '
                         f'floor under {scene})', '-', f"{fan[n]:.0f} exchanges/s ({scene}: "
                         f"{row['lockstep_rate_steps_per_s'] / fan[n]:.2f} of it)", commit))
    return rows


def servo_compare_results(r: dict[str, Any], commit: str) -> list[Row]:
    """The key result of the servo_compare study (`make servo-compare` timed)."""
    sc = r.get('servo_compare')
    if not sc:
        return []
    return [(f"`make servo-compare`: {sc['runs']} runs through the composed nodes",
             '< 6 min', f"{sc['wall_s'] / 60:.1f} min ({sc['sim_s']:.0f} s simulated, "
             f"{sc['jobs']} jobs)", commit)]


def key_results(r: dict[str, Any]) -> list[Row]:
    """(figure, goal, measured, commit) of every headline figure the data holds."""
    c, ls = r['calibration'], r['lockstep']
    commit = f"`{commit_of(r, 'calibration')}`"
    rows: list[Row] = []
    if c.get('figures_004'):
        ok = sum(1 for f in c['figures_004'] if f['ok'])
        rows.append(("004's figures on its full grids within issue 18's tolerances",
                     f"{len(c['figures_004'])} of {len(c['figures_004'])}",
                     f"{ok} of {len(c['figures_004'])}", commit))
    rows += [
        ('isometric gain at x = 0 mm, dynamic bench on a 0.5 V grid', '284.3 N/V (004) +-10 %',
         f"{c['isometric_gain_N_per_V_at_0mm']:.1f} N/V", commit),
        ('isometric gain at x = 95 mm, dynamic bench on a 0.5 V grid', '17.4 N/V (004) +-10 %',
         f"{c['isometric_gain_N_per_V_at_95mm']:.1f} N/V", commit),
        ('contraction at 6 V, 50 N', '>= 100 mm (004)',
         f"{c['contraction_mm_at_6V_50N']:.1f} mm", commit),
        ('force at 6 V, x = 0', '>= 900 N (004)', f"{c['force_N_at_6V_0mm']:.0f} N", commit)]
    commit = f"`{commit_of(r, 'lockstep')}`"
    rows += [
        ('one lock-step exchange (demo, 7 participants)', 'a few round trips',
         f"{1 / ls['ratio_lockstep_to_pingpong']:.1f} round trips "
         f"({ls['demo_lockstep_steps_per_s']:.0f} exchanges/s against "
         f"{ls['pingpong_round_trips_per_s']:.0f} round trips/s)", commit)]
    rows += _layout_results(r)
    rows += servo_compare_results(r, f"`{commit_of(r, 'servo_compare')}`")
    rows += wallclock_results(r, f"`{commit_of(r, 'wallclock')}`")
    rows += faults_results(r, f"`{commit_of(r, 'faults')}`")
    rows += straight_fibre_results(r, f"`{commit_of(r, 'straight_fibre')}`")
    rows += calibrate_results(r, f"`{commit_of(r, 'calibrate')}`")
    rows += calibrate_nodes_results(r, f"`{commit_of(r, 'calibrate_nodes')}`")
    commit = f"`{commit_of(r, 'scenes')}`"
    for s in r.get('scenes', []):
        if s['scene'] in ('campaign', 'campaign_quick'):
            goal = '>= 36x real time' if s['scene'] == 'campaign' else '-'
            rows.append((f"`{s['scene']}` through separate-process nodes", goal,
                         f"{s['real_time_factor']:.1f}x ({s['wall_s_lockstep']:.0f} s for "
                         f"{s['sim_s'] / 3600:.2f} h)", commit))
    force, x = _campaign_max(r, 'N'), _campaign_max(r, 'mm')
    if force:
        rows.append(('campaign force readings against the 1 ms reference', '<= 0.2 % FS',
                     f'{force[0]:.3f} N ({_pct(force[1])} % FS)', commit))
    if x:
        rows.append(('campaign contraction readings against the 1 ms reference',
                     '<= 0.2 % of the 210 mm belt travel (0.42 mm)', f'{x[0]:.3f} mm', commit))
    wp = r.get('work_precision')
    commit = f"`{commit_of(r, 'work_precision')}`"
    if wp:
        rows.append(('exact ZOH of the valve against its closed form', '<= 1e-12 relative',
                     f"{wp['zoh_max_relative_error']:.1e}", commit))
    ex = r.get('extraction')
    commit = f"`{commit_of(r, 'extraction')}`"
    if ex:
        idf = ex['identification']
        rows.append(('extraction of a campaign-sized bag, figures included', '< 30 s',
                     f"{idf['campaign_extract_s']:.1f} s", commit))
        rows.append((f"step fits ({idf['records']} records)", '< 10 s',
                     f"{idf['fits_s']:.2f} s on {idf['workers']} cores", commit))
    commit = f"`{commit_of(r, 'servo')}`"
    for row in r.get('servo', []):
        if row['scene'] == 'servo_sin_t' and row['controller'] == 'dynamic_inverse_pid':
            rows.append((f"servo_sin_t torque RMS, dynamic inverse + PID ({row['engine']})",
                         '-', f"{row['rms_error']:.3f} {row['unit']} at "
                         f"{row['real_time_factor']:.2f}x real time", commit))
    return rows


def _layouts(r: dict[str, Any]) -> list[str]:
    lay = r['layouts']
    pp = lay['pingpong_round_trips_per_s']
    fan = lay.get('fanout_exchanges_per_s', {})
    floor = (['A lock-step with no work in the same run (one process ticks, N processes '
              'spinning as the nodes do acknowledge, the next tick when all have: '
              '`benchmarks.pingpong.fanout_rate`): ' + ', '.join(
                  f'{n} participant{"s" if n != "1" else ""} {v:.0f} exchanges/s'
                  for n, v in fan.items()) + '. The demo has 7 participants, servo_sin_t 10.',
              ''] if fan else [])
    return [f'rclpy ping-pong floor in the same run: {pp:.0f} round trips/s.', ''] + floor + table(
        ['scene', 'layout', 'sim time', 'exchanges', 'exchanges/s', 'real-time factor',
         'wall s (lock-step)', 'wall s with start-up', 'round trips per exchange'],
        [(row['scene'], row['layout'], f"{row['sim_s']:.0f} s", row['exchange_steps'],
          f"{row['lockstep_rate_steps_per_s']:.0f}", f"{row['real_time_factor']:.2f}x",
          f"{row['wall_s_lockstep']:.1f}", f"{row['wall_s_total']:.1f}",
          _pct(row['round_trips_per_exchange'], 1)) for row in lay['rows']]) + _best_case(r)


PARTICIPANTS = {'demo': '7', 'servo_sin_t': '10'}


def _best_case(r: dict[str, Any]) -> list[str]:
    """The separate-process rate a scene's messages allow: each delivery (clock tick,
    acknowledgement or data message to one subscriber) costs the CPU one delivery of the
    no-work lock-step costs there (cores / its rate / 2 N deliveries), the nodes' work is the
    composed run's, and both spread over every core. Without a delivery count, the data
    messages are taken as free. An estimate from the same run, not a bound: a data message
    costs more to deliver than a clock tick, and the work cannot fill every core."""
    lay = r['layouts']
    fan = lay.get('fanout_exchanges_per_s', {})
    cpus = r.get('machine', {}).get('cpus', 2)
    rows = {(row['scene'], row['layout']): row for row in lay['rows']}
    parts = []
    counted = False
    for scene, n in PARTICIPANTS.items():
        one = rows.get((scene, 'one process'))
        if n not in fan or one is None:
            continue
        sep = rows.get((scene, 'separate processes'))
        step_s = one['sim_s'] / one['exchange_steps']
        floor_s = 1.0 / fan[n]                       # wall s per no-work exchange
        work_s = 1.0 / one['lockstep_rate_steps_per_s'] / cpus
        deliveries = one.get('deliveries_per_exchange')
        if deliveries:
            counted = True
            per_delivery_s = cpus * floor_s / (2 * int(n))    # CPU s per delivery
            rate = 1.0 / (deliveries * per_delivery_s / cpus + work_s)
            what = f'{deliveries:.1f} deliveries at {per_delivery_s * 1e6:.0f} us, '
        else:
            rate = 1.0 / (floor_s + work_s)
            what = ''
        measured = (f", measured {sep['lockstep_rate_steps_per_s']:.0f}/s" if sep else '')
        parts.append(f"{scene} {what}{rate:.0f} exchanges/s ({rate * step_s:.2f}x real time, "
                     f"{rate / lay['pingpong_round_trips_per_s']:.2f} of the ping-pong"
                     f"{measured})")
    if not parts:
        return []
    model = ("every delivery of a message to a subscriber (ticks, acknowledgements and data, "
             "counted in the composed run) at the CPU cost of one delivery of the no-work "
             "lock-step, plus the composed run's work" if counted else
             "the no-work lock-step of the scene's participants plus the composed run's "
             "work, data messages free")
    return ['', f'What separate processes could reach by this estimate ({model}, over {cpus} '
            'cores; not a bound): ' + '; '.join(parts) + '.']


def _profile(r: dict[str, Any]) -> list[str]:
    from pam_bench.benchmarks.profile import CAUSES
    head = ['scene', 'layout', 'wall us / exchange (profiled)'] + list(CAUSES)
    return table(head, [(p['scene'], p['layout'], f"{p['wall_us_per_exchange']:.0f}")
                        + tuple(f"{p['us_per_exchange'][c]:.0f}" for c in CAUSES)
                        for p in r['profile']])


def _calibration(r: dict[str, Any]) -> list[str]:
    c = r['calibration']
    lines: list[str] = []
    if c.get('figures_004'):
        lines += ["Every figure 004 reports, on its full grids (quasi-static bench, the "
                  "extraction's estimators; `verify/figures_004.py` says how each is read):", '']
        lines += table(['figure', '004', 'simulated bench', 'difference', 'tolerance',
                        'within'],
                       [(f['text'], f"{f['paper']:g} {f['unit']}",
                         f"{f['bench']:.4g} {f['unit']}",
                         f"{f['difference'] * 100:+.1f} %" if f['relative']
                         else f"{f['difference']:+.3g} {f['unit']}",
                         '>= 004' if f['at_least'] else f"{f['tolerance'] * 100:g} %"
                         if f['relative'] else f"{f['tolerance']:g} {f['unit']}",
                         'yes' if f['ok'] else 'NO') for f in c['figures_004']])
        sec = c.get('secant_004', {})
        if sec:
            lines += ['', f"004 words the isometric gain as the ratio F/u; read literally as "
                      f"the secant F(6 V) / 6 V it is {sec['0']:.1f} N/V at 0 mm and "
                      f"{sec['95']:.1f} N/V at 95 mm (the slope reading above is the one 004's "
                      '"F ~ k(x) u + F0" fits). The isotonic ratio x/u has no value at u = 0, '
                      "where 004 places its minimum, so it is read as the difference quotient "
                      'between neighbouring readings; the smallest lies at '
                      f"({c['isotonic_min_at'][0]:.2f} V, {c['isotonic_min_at'][1]:.0f} N), "
                      'equal to the 100 N value to 0.001 mm/V.', '',
                      'The dynamic bench on a coarse grid (0.5 V steps, 3 s dwell):', '']
    return lines + table(['figure', 'simulated bench', '004', 'tolerance'], [
        ('isometric gain at x = 0 mm', f"{c['isometric_gain_N_per_V_at_0mm']:.1f} N/V",
         '284.3 N/V', '+-10 % (coarse grid)'),
        ('isometric gain at x = 95 mm', f"{c['isometric_gain_N_per_V_at_95mm']:.1f} N/V",
         '17.4 N/V', '+-10 % (coarse grid)'),
        ('contraction at 6 V, 50 N', f"{c['contraction_mm_at_6V_50N']:.1f} mm", '>= 100 mm',
         '-'),
        ('force at 6 V, x = 0', f"{c['force_N_at_6V_0mm']:.0f} N", '>= 900 N', '-'),
        ('isobaric hysteresis, max', f"{c['isobaric_hysteresis_mm_max']:.2f} mm", 'visible',
         '-')])


def _lockstep(r: dict[str, Any]) -> list[str]:
    ls = r['lockstep']
    return table(['measure', 'rate'], [
        ('rclpy ping-pong, two processes', f"{ls['pingpong_round_trips_per_s']:.0f} round "
         'trips/s'),
        (f"lock-step, demo scene (10 ms exchanges), {ls['participants']} participants in "
         'separate processes', f"{ls['demo_lockstep_steps_per_s']:.0f} exchanges/s"),
        ('ratio lock-step / ping-pong', f"{ls['ratio_lockstep_to_pingpong']:.3f}")])


def _scenes(r: dict[str, Any]) -> list[str]:
    return table(['scene', 'sim time', 'wall time (lock-step)', 'real-time factor',
                  'wall time with start-up', 'exchange steps', 'steps/s'],
                 [(s['scene'], f"{s['sim_s']:.0f} s ({s['sim_s'] / 3600:.2f} h)",
                   f"{s['wall_s_lockstep']:.1f} s", f"{s['real_time_factor']:.1f}x",
                   f"{s['wall_s_total']:.1f} s", s['exchange_steps'],
                   f"{s['lockstep_rate_steps_per_s']:.0f}") for s in r['scenes']])


def _campaign(r: dict[str, Any]) -> list[str]:
    cmp = r['campaign']
    rows: list[Row] = []
    for key, label in (('twin_same_steps', 'scene steps'), ('twin_1ms', '1 ms / 1 ms')):
        t = cmp[key]
        rows += [(label, row['protocol'], row['readings'],
                  f"{row['max_error']:.3f} {row['unit']}", f"{row['p99_error']:.3f}",
                  _pct(row['max_error_pct_fs'])) for row in t['protocols']]
        rec = t['records']
        rows.append((label, 'step records b, c, d', rec['records'],
                     f"{100 * rec['max_bcd_rel_error']:.2f} %",
                     f"1 <-> 5 V: {100 * rec['max_bcd_rel_error_1_5V']:.2f} %", ''))
    t = cmp['twin_1ms']
    return [f"Scene `{cmp['scene']}`.", ''] + table(
        ['twin', 'protocol', 'readings', 'max difference', '99th percentile', '% FS'], rows) + [
        '', f"The 1 ms twin took {t['twin_exchanges']} exchanges and {t['twin_wall_s']:.0f} s "
        'of wall time in one process.']


def _exchange_step(r: dict[str, Any]) -> list[str]:
    return table(['protocol', 'held', 'exchange step', 'sub-step', 'exchanges per reading',
                  'max error', '% FS', 'wall s (reference wall s)'],
                 [(row['protocol'], f"{row['held']:g}", f"{row['exchange_step_s']:g} s",
                   f"{1e3 * row['sub_step_s']:g} ms", f"{row['exchanges_per_reading']:.1f}",
                   f"{row['max_error']:.3f} {row['unit']}", _pct(row['max_error_pct_fs']),
                   f"{row['wall_s']:.2f} ({row['wall_s_1ms']:.1f})")
                  for row in r['exchange_step']])


def _record_exchange(r: dict[str, Any]) -> list[str]:
    return table(['x mm', 'step', 'H', 'exchanges per record', 'largest b, c, d change',
                  'largest force difference', 'wall s (1 ms wall s)'],
                 [(f"{row['x_mm']:.0f}", f"{row['u0_V']:g} -> {row['u1_V']:g} V",
                   f"{1e3 * row['record_exchange_s']:g} ms", row['exchanges'],
                   f"{100 * row['max_abs_rel_error']:.3f} %",
                   f"{row['max_force_difference_N']:.2f} N",
                   f"{row['wall_s']:.2f} ({row['wall_s_1ms']:.2f})")
                  for row in r['record_exchange']])


def _extraction(r: dict[str, Any]) -> list[str]:
    ex = r['extraction']
    rows: list[Row] = []
    for row in ex['scenes']:
        def pct(key: str, row: dict[str, Any] = row) -> str:
            return f'{100 * abs(row[key]):.2f} %' if key in row else '-'

        def bcd(prefix: str, row: dict[str, Any] = row) -> str:
            keys = [f'{prefix}_{c}_max_abs_rel_error' for c in 'bcd']
            return ', '.join(f'{100 * row[k]:.1f} %' for k in keys) if keys[0] in row else '-'
        for against, suffix, step in (('parameters', '', 'step_fits'),
                                      ('reference', '_reference', 'step_reference_fits')):
            rows.append((row['scene'], against,
                         pct(f'isometric_gain{suffix}_max_abs_rel_error'),
                         pct(f'isotonic_gain{suffix}_max_rel_error'),
                         pct(f'isobaric_hysteresis{suffix}_rel_error'), bcd(step)))
    idf = ex['identification']
    speed = table(['what', 'wall time'], [
        (f"{idf['records']} step fits (1 s at 1 kHz, noise on), {idf['workers']} cores",
         f"{idf['fits_s']:.2f} s"),
        ('whole extraction of that bag', f"{idf['extract_s']:.2f} s"),
        (f"a bag the size of the {'quick' if r['quick'] else 'full'} campaign "
         f"({idf['campaign_points']} points and those records), figures included",
         f"{idf['campaign_extract_s']:.1f} s")])
    return table(['scene', 'against', 'isometric gain', 'isotonic max gain',
                  'isobaric hysteresis', 'step b, c, d'], rows) + [''] + speed


def _work_precision(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    from pam_bench.benchmarks.sections import plot_work_precision
    wp = r['work_precision']
    fastest = [(model, f"{row['scheme']} at {row['step_s'] * 1e3:g} ms "
                       f"({row['relative_error']:.1e})" if row else 'none of the steps tried')
               for model, row in wp['fastest_within_0.1pct'].items()]
    return ([f"![work-precision]({plot_work_precision(wp['rows'], root)})", '']
            + table(['model', 'scheme', 'step', 'relative error', 'wall s / sim s'],
                    [(row['model'], row['scheme'], f"{row['step_s'] * 1e3:g} ms",
                      f"{row['relative_error']:.2e}", f"{row['wall_s_per_sim_s']:.4f}")
                     for row in wp['rows']])
            + ['', 'Fastest scheme within 0.1 %:', ''] + table(['model', 'scheme'], fastest)
            + ['', f"Exact ZOH of the valve against the closed form: largest relative error "
               f"{wp['zoh_max_relative_error']:.1e}."])


def _fidelity(r: dict[str, Any]) -> list[str]:
    return table(['scene', 'option', 'quantity', 'change', 'tolerance', 'within', 'wall s',
                  'speed-up'],
                 [(row['scene'], row['option'], row['quantity'],
                   f"{row['change']:.3g} {row['unit']}", f"{row['tolerance']:g}",
                   'yes' if row['within'] else 'no', f"{row['wall_s']:.2f}",
                   f"{row['speed_up']:.2f}x") for row in r['fidelity']])


def _ros_exchange_step(r: dict[str, Any]) -> list[str]:
    return table(['scene', 'exchange step', 'wall s', 'real-time factor', 'error', '% FS'],
                 [(row['scene'], f"{row['exchange_step_s'] * 1e3:g} ms",
                   f"{row['wall_s']:.1f}", f"{row['real_time_factor']:.2f}x",
                   f"{row['max_error']:.3f} {row['unit']}", _pct(row['pct_fs']))
                  for row in r['ros_exchange_step']['rows']])


def _servo(r: dict[str, Any]) -> list[str]:
    return table(['scene', 'controller', 'engine', 'RMS error', 'max', 'at reversal',
                  'elsewhere', 'real-time factor'],
                 [(row['scene'], row['controller'], row['engine'],
                   f"{row['rms_error']:.3f} {row['unit']}", f"{row['max_error']:.3f}",
                   f"{row['error_at_reversal']:.3f}", f"{row['error_elsewhere']:.3f}",
                   f"{row['real_time_factor']:.2f}x") for row in r['servo']])


def _servo_compare(r: dict[str, Any]) -> list[str]:
    sc = r['servo_compare']
    return [f"{sc['runs']} runs, {sc['sim_s']:.0f} s simulated, in {sc['wall_s']:.0f} s of wall "
            f"time with {sc['jobs']} jobs.", ''] + table(
        ['scene', 'controller', 'RMS error', 'max', 'sim s', 'wall s', 'real-time factor'],
        [(row['scene'], row['controller'], f"{row['rms_error']:.3f} {row['unit']}",
          f"{row['max_error']:.3f}", f"{row['sim_s']:.0f}", f"{row['wall_s']:.1f}",
          f"{row['real_time_factor']:.2f}x") for row in sc['rows']])


SECTIONS: list[tuple[str, Callable[..., list[str]]]] = [
    ('calibration', _calibration), ('lockstep', _lockstep), ('layouts', _layouts),
    ('profile', _profile), ('scenes', _scenes),
    ('campaign', _campaign), ('exchange_step', _exchange_step),
    ('record_exchange', _record_exchange), ('extraction', _extraction),
    ('work_precision', _work_precision), ('fidelity', _fidelity),
    ('ros_exchange_step', _ros_exchange_step), ('servo', _servo),
    ('wallclock', wallclock_section), ('faults', faults_section),
    ('straight_fibre', straight_fibre_section), ('calibrate', calibrate_section),
    ('calibrate_nodes', calibrate_nodes_section), ('servo_compare', _servo_compare)]
"""Section key (of bench.json and methods.yaml) and its table renderer, in report order."""


def render(r: dict[str, Any], root: pathlib.Path) -> str:
    """BENCHMARKS.md from a report (plots are written into ``root``)."""
    m = r['machine']
    lines = ['# pam_bench benchmarks', '',
             f"Measured in one run of `pam-bench bench{' --quick' if r['quick'] else ''}` on "
             f"{m['platform']}, {m['cpus']} CPUs, Python {m['python']}, last run {r['date']} "
             f"at commit `{r['commit']}`; a study rerun alone (`pam-bench bench --only`) "
             'keeps its own commit, named in its section and in the key results. Raw figures: '
             '`bench.json`. Each section says how its figures are measured; code cites these '
             'sections by title instead of quoting figures.',
             '', '## Key results', ''] + table(['figure', 'goal', 'measured', 'commit'],
                                               key_results(r))
    for key, section in SECTIONS:
        if not r.get(key):
            continue
        text = methods()[key]
        lines += ['', f"## {text['title']}", '',
                  text['method'] + f' (Commit `{commit_of(r, key)}`.)', '']
        lines += section(r, root) if key == 'work_precision' else section(r)
    long_runs = root / LONG_RUNS
    if long_runs.exists():
        lines += ['', long_runs.read_text(encoding='utf-8').strip()]
    return '\n'.join(lines) + '\n'
