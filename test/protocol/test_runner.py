"""The runner's policies on a wall clock: a goal cancelled or given up before it starts."""

from __future__ import annotations

import pytest

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.runner import END_CODES, Runner
from pam_bench.protocol.schedules import Direction, Reading
from pam_bench.protocol.sequencer import Phase, Sequencer
from pam_bench.protocol.settings import RunnerSettings


def _loaded() -> Runner:
    readings = [Reading('isometric', 0, 0, Direction.UP, 0.0, 2.0, 2.0, LoadMode.POSITION,
                        0.0, 0.3)]
    run = Runner(RunnerSettings(), lockstep=False, end_run=False)
    run.load(Sequencer('iso', readings, settle_s=0.1))
    return run


@pytest.mark.parametrize('end, phase', [
    (lambda run: run.cancel(), Phase.CANCELLED),
    (lambda run: run.abort_start('no data on load_cell_1/force'), Phase.ABORTED),
])
def test_a_protocol_waiting_for_its_inputs_ends_when_told(end, phase) -> None:
    run = _loaded()
    tick = run.tick(0.0)
    assert tick.waiting == ['force', 'contraction', 'pressure', 'drive'] and not run.ended
    end(run)
    tick = run.tick(0.01)
    assert run.ended and not run.busy and run.core is not None and run.core.phase == phase
    assert not tick.waiting and tick.commands.voltage_v == 0.0
    assert tick.commands.load_mode == LoadMode.OFF and END_CODES[phase] in (4, 5)


def test_abort_start_leaves_a_started_protocol_alone() -> None:
    run = _loaded()
    for name in ('force', 'contraction', 'pressure', 'drive'):
        run.measured(name, 0.0, 0.0)
    assert run.tick(0.0).commands.voltage_v == 2.0          # started: settling at 2 V
    run.abort_start('late')
    assert run.core is not None and run.core.phase == Phase.SETTLE


def test_a_drive_that_stops_following_suspends_the_run_until_it_follows_again() -> None:
    """The loading servo's state stops (a CANopen drive in fault, quick stop or silent): a
    suspender on ``drive`` pauses the run, vented, instead of reading at a wrong position; the
    run resumes once the state has come again for ``resume_after_s``."""
    readings = [Reading('isometric', 0, 0, Direction.UP, 0.0, 2.0, 2.0, LoadMode.POSITION,
                        0.0, 0.3)]
    run = Runner(RunnerSettings(suspenders_yaml='[{input: drive, stale_s: 0.2, '
                                                'resume_after_s: 0.3}]', stale_timeout_s=0.5),
                 lockstep=False, end_run=False)
    run.load(Sequencer('iso', readings, settle_s=1.0))
    t = 0.0
    notes: list[str] = []

    def tick(drive: bool) -> None:
        nonlocal t
        for name in ('force', 'contraction', 'pressure') + (('drive',) if drive else ()):
            run.measured(name, 0.0, t)
        notes.extend(n.text for n in run.tick(t).notes)
        t = round(t + 0.01, 6)

    for _ in range(20):
        tick(True)
    assert run.core is not None and run.core.phase == Phase.SETTLE
    for _ in range(40):                      # 0.4 s without the drive's state
        tick(False)
    assert run.core.phase == Phase.PAUSED and run.suspenders.suspended
    assert any(n.startswith('protocol suspended: drive stale') for n in notes), notes
    for _ in range(20):                      # back, but not yet for resume_after_s
        tick(True)
    assert run.core.phase == Phase.PAUSED
    for _ in range(20):
        tick(True)
    assert run.core.running and run.core.phase != Phase.PAUSED and not run.suspenders.suspended
