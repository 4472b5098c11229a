"""Pause and resume in lock-step (the numpy twin runs the sequencer's own state machine):
paused twice and resumed, held, the readings equal those of an uninterrupted run.

Equal to what the bench itself resolves: the pressures agree to 1e-9 Pa, but the loading
servo's position loop reads a 16-bit encoder, so where it holds the muscle end depends on its
history within one count (3.05 um); the force then differs by that count times the muscle's
stiffness (measured: at most 0.04 N, 0.002 % of full scale)."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.models.sensors import LoadCellParams
from pam_bench.protocol.sequencer import Phase
from pam_bench.twin.protocol_run import run_protocol

OVERRIDES = {'x_m': [0.04, 0.04, 0.01], 'voltage_v': [0.0, 3.0, 1.0], 'dwell_s': 3.0}
QUIET = LoadCellParams(noise=False, quantise=False)    # the physics alone is compared


def _run(events: list[tuple[float, str]] = ()):
    return run_protocol('isometric_quick', 0.01, overrides=OVERRIDES, load_cell=QUIET,
                        events=events)


def test_paused_twice_and_resumed_gives_the_same_readings() -> None:
    plain = _run()
    # one pause in a dwell (reading 1), one while settled after reading 4 was taken
    paused = _run([(4.2, 'pause'), (9.7, 'resume'), (17.5, 'pause'), (25.0, 'resume')])
    assert len(plain.points) == len(paused.points) == 8
    assert paused.sim_s > plain.sim_s + 10.0            # the pauses took their time
    key = [(p.reading.series, p.reading.step) for p in plain.points]
    assert key == [(p.reading.series, p.reading.step) for p in paused.points]
    f0 = np.array([p.measurement.force_n for p in plain.points])
    f1 = np.array([p.measurement.force_n for p in paused.points])
    x0 = np.array([p.measurement.contraction_m for p in plain.points])
    x1 = np.array([p.measurement.contraction_m for p in paused.points])
    np.testing.assert_allclose(f1, f0, rtol=0, atol=0.1)         # N: one encoder count
    np.testing.assert_allclose(x1, x0, rtol=0, atol=3.1e-6)      # m: one encoder count
    p0 = np.array([p.measurement.pressure_pa for p in plain.points])
    p1 = np.array([p.measurement.pressure_pa for p in paused.points])
    np.testing.assert_allclose(p1, p0, rtol=0, atol=1e-3)        # Pa


def test_a_vented_pause_settles_again_and_still_takes_every_reading() -> None:
    run = _run([(4.2, 'pause_vent'), (8.0, 'resume')])
    assert len(run.points) == 8
    assert all(np.isfinite(p.measurement.force_n) for p in run.points)


@pytest.mark.parametrize('phase_before', [Phase.SETTLE, Phase.DWELL])
def test_pause_and_resume_state_machine(phase_before: Phase) -> None:
    from pam_bench.config.protocols import protocol_schedule
    from pam_bench.protocol.sequencer import Measurement, Sequencer
    readings, settle = protocol_schedule('isometric_quick', OVERRIDES)
    seq = Sequencer('isometric_quick', readings, settle)
    seq.start(0.0)
    meas = Measurement(0.0, 0.04, 0.0)
    t = 0.0 if phase_before == Phase.SETTLE else settle + 0.5
    seq.tick(t, meas)
    assert seq.phase == phase_before
    seq.pause('supply pressure low', vent=True)
    cmd = seq.tick(t + 0.1, meas)
    assert seq.phase == Phase.PAUSED and seq.pause_reason == 'supply pressure low'
    assert cmd.voltage_v == 0.0 and int(cmd.load_mode) == 0        # vented, drive off
    assert seq.running and seq.next_event_s(t + 0.1) == float('inf')
    left = seq.remaining_s(t + 0.1)
    assert seq.remaining_s(t + 50.0) == pytest.approx(left)        # a pause costs no schedule
    seq.resume()
    seq.tick(t + 50.0, meas)
    assert seq.phase == Phase.SETTLE and seq.paused_s == pytest.approx(49.9)


def _suspended(high_n: float, action: str = 'hold', max_sim_s: float = 300.0):
    from pam_bench.protocol.settings import RunnerSettings
    rule = f'[{{input: force, high: {high_n}, resume_after_s: 0.5}}]'
    return run_protocol('isometric_quick', 0.01, overrides=OVERRIDES, load_cell=QUIET,
                        runner=RunnerSettings(suspenders_yaml=rule, pause_action=action),
                        max_sim_s=max_sim_s)


def test_a_suspender_holds_through_the_overshoot_and_the_readings_stay() -> None:
    """The valve's step at 3 V overshoots (2nd order, zeta 0.3): a force bound 10 % over the
    settled 3 V force trips in the transient, the run holds, resumes once the force has been
    back in band for 0.5 s, dwells the reading again and takes the same readings (the
    suspenders run in the twin as in the node: ``protocol.runner``)."""
    plain = _run()
    f_top = max(p.measurement.force_n for p in plain.points)
    run = _suspended(1.1 * f_top)
    assert run.suspensions >= 1 and run.paused_s > 0.5
    assert run.exit_code == 0 and len(run.points) == len(plain.points)
    f0 = np.array([p.measurement.force_n for p in plain.points])
    f1 = np.array([p.measurement.force_n for p in run.points])
    np.testing.assert_allclose(f1, f0, rtol=0, atol=0.1)         # N: one encoder count


def test_no_suspension_when_the_band_holds() -> None:
    plain = _run()
    run = _suspended(10.0 * max(p.measurement.force_n for p in plain.points))
    assert run.suspensions == 0 and run.paused_s == 0.0
    np.testing.assert_array_equal([p.measurement.force_n for p in run.points],
                                  [p.measurement.force_n for p in plain.points])


def test_a_vented_suspension_trips_again_at_every_new_start() -> None:
    """Vented, the muscle deflates, the band holds, the run resumes and settles again from
    0 V, which overshoots again: the suspender holds the run at that reading (the readings
    before it are taken, none past it) until the run is stopped."""
    from pam_bench.twin.protocol_run import TIMED_OUT
    plain = _run()
    top = max(range(len(plain.points)), key=lambda i: plain.points[i].measurement.force_n)
    run = _suspended(1.1 * plain.points[top].measurement.force_n, 'vent', max_sim_s=60.0)
    assert run.exit_code == TIMED_OUT and run.suspensions >= 3
    assert len(run.points) <= top
