"""Injected faults tried on the wall clock: each kind detected, survived or resumable, how
many readings were lost and how long the bench took to reach its safe state.

Each case runs a short isometric series (4 settled readings at 0, 1, 1 and 0 V, 1.5 s apart,
the first at 3.0 s) with one fault from a scene's ``faults`` list and a force suspender (band
and stale bound) on the sequencer. Faults start inside a dwell: a reading is one load-cell
sample, so a noise burst whose first sample falls on a reading instant and stays in the band
would pass into that reading unseen (measured once in CI-like runs: 129 N on a 0.8 N reading).
Detected: the reason appears on ``protocol/status`` (paused or aborted); survived: the run
ended done with every reading; lost: readings of the schedule the bag lacks and a resume would
not take (a resumable abort loses none); time to safe state: from the fault's start (on the
run's clock, the first status) to the first paused status or vented command.
"""

from __future__ import annotations

import pathlib
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.vocabulary.run import Layout, RunOptions

__all__ = ['STUDY', 'SCENE', 'READINGS', 'CASES', 'measure_faults', 'faults_section',
           'faults_results']

SCENE = """description: short isometric series with an injected fault
exchange_step_s: 1.5
protocol: isometric_quick
protocol_overrides: {{x_m: [0.04, 0.04, 0.01], voltage_v: [0.0, 1.0, 1.0], dwell_s: 1.5}}
nodes: [valve_1, muscle_1, load_cell_1, encoder, loading_servo, sequencer, recorder]
parameters:
  sequencer: {{suspenders_yaml: "[{{input: force, low: -50.0, high: 1000.0, stale_s: 0.2,
    resume_after_s: 0.3}}]"}}
faults: [{fault}]
"""
READINGS = 4

CASES = {
    # kind: (fault entry, survives, words in the reason)
    'sensor_dropout': ('{kind: sensor_dropout, target: load_cell_1, at_s: 3.6, '
                       'duration_s: 0.6}', True, 'force stale'),
    'sensor_drift': ('{kind: sensor_drift, target: load_cell_1, at_s: 3.6, duration_s: 0.4, '
                     'value: 4000.0}', True, 'outside'),
    'sensor_noise_burst': ('{kind: sensor_noise_burst, target: load_cell_1, at_s: 3.6, '
                           'duration_s: 0.5, value: 300.0}', True, 'outside'),
    'message_loss': ('{kind: message_loss, target: load_cell_1, at_s: 2.0, duration_s: 3.0, '
                     'value: 0.5}', True, ''),
    # stuck from before the first 1 V command (after the first reading's 1.5 s dwell, at the
    # earliest) to past the reading at 1 V, however long the loading servo takes to settle
    'valve_stuck': ('{kind: valve_stuck, target: valve_1, at_s: 1.0, duration_s: 6.0}', False,
                    'valve does not follow'),
    # after the second reading's dwell: a device stalled 0.2 s before the first reading (load
    # on the machine) suspends and restarts that dwell, and the kill must still find a
    # reading to keep
    'node_kill': ('{kind: node_kill, target: encoder, at_s: 5.0}', False, 'stale'),
}


def _stamp(msg: Any) -> int:
    return int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec)


def _case(kind: str, out: pathlib.Path) -> dict[str, Any]:
    from pam_bench.bags.bagread import topic_messages
    fault, survives, words = CASES[kind]
    path = out / f'fault_{kind}.yaml'
    path.write_text(SCENE.format(fault=fault), encoding='utf-8')
    scene = load_scene(str(path))
    bag = out / f'fault_{kind}'
    res = run_scene(scene, str(bag), RunOptions(layout=Layout.WALL_CLOCK, quiet=True))
    status = topic_messages(bag, '/protocol/status')
    points = topic_messages(bag, '/protocol/point')
    t_fault = _stamp(status[0]) + round(scene.faults[0].at_s * 1e9) if status else 0
    flagged = [s for s in status if s.phase == 'paused' or s.state == 3]
    detected = bool(flagged) and words in flagged[0].reason if words else None
    safe = [_stamp(s) for s in status if s.phase == 'paused' and _stamp(s) >= t_fault]
    safe += [_stamp(m) for m in topic_messages(bag, '/loading_servo/command')
             if m.mode == 0 and _stamp(m) >= t_fault]
    taken = {(p.series, p.step) for p in points}
    resumable = res.code == 4
    return {'kind': kind, 'code': res.code, 'detected': detected,
            'reason': flagged[0].reason if flagged else '',
            'survived': res.code == 0 and len(taken) == READINGS,
            'resumable': resumable, 'readings': len(taken),
            'lost': 0 if resumable else READINGS - len(taken),
            'to_safe_s': (min(safe) - t_fault) * 1e-9 if safe else None}


QUICK_CASES = ('sensor_dropout', 'node_kill')
"""``--quick``: one fault of each outcome (a stale input survived, a process gone: aborted
and resumable)."""


def measure_faults(out: pathlib.Path, quick: bool = False) -> list[dict[str, Any]]:
    """Run every case of ``CASES`` (module docstring); ``QUICK_CASES`` when quick."""
    rows = []
    for kind in QUICK_CASES if quick else CASES:
        print(f'  fault {kind} ...', flush=True)
        rows.append(_case(kind, out))
    return rows


def faults_section(r: dict[str, Any]) -> list[str]:
    """The fault table."""
    return table(['fault', 'detected', 'reason', 'outcome', 'readings taken', 'readings lost',
                  'time to safe state'],
                 [(row['kind'], {True: 'yes', False: 'NO', None: 'tolerated'}[row['detected']],
                   row['reason'] or '-',
                   'survived' if row['survived'] else
                   'aborted, resumable' if row['resumable'] else f"exit {row['code']}",
                   f"{row['readings']} of {READINGS}", row['lost'],
                   '-' if row['to_safe_s'] is None else f"{row['to_safe_s'] * 1e3:.0f} ms")
                  for row in r['faults']])


def faults_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result row: kinds tried, detected, readings lost."""
    rows = r.get('faults')
    if not rows:
        return []
    detected = sum(1 for x in rows if x['detected'] is not False)
    ok = sum(1 for x in rows if x['survived'] or x['resumable'])
    lost = sum(x['lost'] for x in rows)
    return [('injected faults on the wall clock: detected, survived or resumable, readings lost',
             'all, all, 0', f'{detected} of {len(rows)}, {ok} of {len(rows)}, {lost}', commit)]


STUDY = Study(
    'faults', 'injected faults on the wall clock: detected, survived, readings lost',
    lambda quick, out, scenes: {'faults': measure_faults(out, quick)},
    (('faults', lambda r, root: faults_section(r)),),
    lambda r: faults_results(r, commit_of(r, 'faults')))
"""Injected faults on the wall clock (bench.json ``faults``)."""
