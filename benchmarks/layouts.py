"""Study ``layouts``: the same scenes in separate processes and composed, beside the no-work
lock-step floor and the ping-pong measured in the same run; and what separate processes could
reach (``_best_case``)."""

from __future__ import annotations

import pathlib
from typing import Any

from benchmarks.runs import scene_bag, scene_run
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, pct, table
from pam_bench.bringup.pingpong import pingpong_rate
from pam_bench.vocabulary.run import Layout

__all__ = ['STUDY', 'measure', 'section', 'results', 'PARTICIPANTS']

PARTICIPANTS = {'demo': '7', 'servo_sin_t': '10'}
"""Lock-step participants of the scenes the estimate covers."""


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """The same scenes in both layouts, next to the ping-pong floor measured with them."""
    pp = pingpong_rate(3000)
    from pam_bench.bringup.pingpong import fanout_rate
    fanout = {}
    for n in (1, 7) if quick else (1, 7, 10):
        print(f'  lock-step with no work, {n} participants ...', flush=True)
        fanout[str(n)] = fanout_rate(n, 1000 if quick else 2000)
    rows = []
    for name in ('demo', 'servo_sin_t', 'campaign_quick') + (() if quick else ('campaign',)):
        for layout in (Layout.PROCESSES, Layout.COMPOSED):
            print(f'  {name}, {layout.value} ...', flush=True)
            if quick and name != 'demo' and layout is Layout.PROCESSES:
                continue             # separate processes: the demo shows them (the rest, about
                #                      25 s, in the full run)
            row = scene_run(name, out, layout)
            if name.startswith('servo'):
                from pam_bench.twin.servo_bench import tracking_metrics
                from pam_bench.twin.servo_setup import servo_run_of_bag
                run = servo_run_of_bag(scene_bag(name, out, layout), 2)
                row['torque_rms_error_nm'] = tracking_metrics(run)['rms_error']
            row['round_trips_per_exchange'] = pp / row['lockstep_rate_steps_per_s'] \
                if row['lockstep_rate_steps_per_s'] else None
            rows.append(row)
    return {'layouts': {'pingpong_round_trips_per_s': pp, 'fanout_exchanges_per_s': fanout,
                        'rows': rows}}


def _layout_row(r: dict[str, Any], scene: str, layout: Layout) -> dict[str, Any] | None:
    """The layouts study's row of ``scene`` in ``layout``, if it was measured."""
    for row in r.get('layouts', {}).get('rows', []):
        if row['scene'] == scene and Layout.parse(row['layout']) is layout:
            return row
    return None


def results(r: dict[str, Any]) -> list[Row]:
    """servo_sin_t in both layouts, the campaigns composed, the demo against the floor."""
    if not r.get('layouts'):
        return []
    commit = commit_of(r, 'layouts')
    pp = r['layouts']['pingpong_round_trips_per_s']
    rows: list[Row] = []
    for layout, goal in ((Layout.COMPOSED, '>= 1x real time'),
                         (Layout.PROCESSES, '>= 0.3x real time')):
        row = _layout_row(r, 'servo_sin_t', layout)
        if row:
            rms = (f", torque RMS {row['torque_rms_error_nm']:.4f} N m"
                   if 'torque_rms_error_nm' in row else '')
            rows.append((f'`servo_sin_t` (8 s, 1 ms exchanges), {layout.value}', goal,
                         f"{row['real_time_factor']:.2f}x ({row['lockstep_rate_steps_per_s']:.0f}"
                         f' exchanges/s{rms})', commit))
    row = _layout_row(r, 'campaign_quick', Layout.COMPOSED)
    if row:
        rows.append(('`campaign_quick` wall time with start-up, composed', '<= 6 s',
                     f"{row['wall_s_total']:.1f} s ({row['real_time_factor']:.0f}x in "
                     'lock-step)', commit))
    row = _layout_row(r, 'campaign', Layout.COMPOSED)
    if row:
        rows.append(('full `campaign` lock-step, composed', '<= 150 s (>= 146x)',
                     f"{row['wall_s_lockstep']:.0f} s ({row['real_time_factor']:.0f}x)",
                     commit))
    row = _layout_row(r, 'demo', Layout.PROCESSES)
    if row:
        rows.append(('demo lock-step against the ping-pong floor, separate processes',
                     '>= 0.3', f"{row['lockstep_rate_steps_per_s'] / pp:.3f} "
                     f"({row['lockstep_rate_steps_per_s']:.0f} exchanges/s, {pp:.0f} round "
                     'trips/s)', commit))
    fan = r['layouts'].get('fanout_exchanges_per_s', {})
    for scene, n in (('demo', '7'), ('servo_sin_t', '10')):
        row = _layout_row(r, scene, Layout.PROCESSES)
        if row and n in fan:
            rows.append((f'lock-step with no work, {n} separate-process participants (the '
                         f'floor under {scene})', '-', f"{fan[n]:.0f} exchanges/s ({scene}: "
                         f"{row['lockstep_rate_steps_per_s'] / fan[n]:.2f} of it)", commit))
    return rows


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """The floor, the rows of both layouts and the best-case estimate."""
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
        [(row['scene'], Layout.parse(row['layout']).value, f"{row['sim_s']:.0f} s",
          row['exchange_steps'],
          f"{row['lockstep_rate_steps_per_s']:.0f}", f"{row['real_time_factor']:.2f}x",
          f"{row['wall_s_lockstep']:.1f}", f"{row['wall_s_total']:.1f}",
          pct(row['round_trips_per_exchange'], 1)) for row in lay['rows']]) + _best_case(r)


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
    rows = {(row['scene'], Layout.parse(row['layout'])): row for row in lay['rows']}
    parts = []
    counted = False
    for scene, n in PARTICIPANTS.items():
        one = rows.get((scene, Layout.COMPOSED))
        if n not in fan or one is None:
            continue
        sep = rows.get((scene, Layout.PROCESSES))
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


STUDY = Study('layouts', 'scenes in separate processes and composed, beside the lock-step floor',
              measure, (('layouts', section),), results)
"""Both layouts against the ping-pong floor (bench.json ``layouts``)."""
