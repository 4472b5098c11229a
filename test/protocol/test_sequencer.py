"""The sequencer state machine: dwell timing, aborts, step records by stamp, resume."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.schedules import schedule_from_config
from pam_bench.protocol.sequencer import Measurement, Phase, Sequencer
from pam_bench.vocabulary.errors import ParameterError
from test.protocol.test_schedules import QUICK_ISO, STEP


def test_sequencer_reads_after_each_dwell() -> None:
    readings, settle = schedule_from_config(
        'q', {'kind': 'isotonic', 'force_n': [100, 200, 100], 'voltage_v': [0, 1, 0.5],
              'dwell_s': 3.0, 'settle_s': 2.0})
    times = run(Sequencer('q', readings, settle))
    assert len(times) == len(readings) == 12
    np.testing.assert_allclose(np.diff(times), 3.0, atol=1e-9)
    np.testing.assert_allclose(times[0], 5.0, atol=1e-9)


def run(seq: Sequencer, h: float = 0.01, bias_n: float = 0.0) -> list[float]:
    """Tick with a fake bench that follows the set values; return the reading times."""
    seq.start(0.0)
    t, times = 0.0, []
    cmd = seq.tick(0.0, Measurement(0.0, 0.0, 0.0))
    while seq.running and t < 1e5:
        t = round(min(t + h, seq.next_event_s(t)), 9)
        f = cmd.load_value + bias_n if cmd.load_mode == LoadMode.FORCE else 100.0
        x = cmd.load_value if cmd.load_mode == LoadMode.POSITION else 0.01
        cmd = seq.tick(t, Measurement(f, x, 1e5 * cmd.voltage_v))
        if cmd.point is not None:
            times.append(cmd.point.t_s)
    if seq.phase == Phase.DONE:
        assert cmd.voltage_v == 0.0                       # vented when done
    return times


def test_abort_when_servo_misses_set_value() -> None:
    readings, settle = schedule_from_config(
        'q', {'kind': 'isotonic', 'force_n': [100, 200, 100], 'voltage_v': [0, 1, 0.5]})
    seq = Sequencer('q', readings, settle)
    times = run(seq, bias_n=40.0)
    assert seq.phase == Phase.ABORTED and 'cannot reach' in seq.reason and times == []
    assert seq.tick(100.0, Measurement(0, 0, 0)).voltage_v == 0.0
    assert seq.tick(100.0, Measurement(0, 0, 0)).load_mode == LoadMode.OFF


def test_abort_when_load_cell_out_of_range() -> None:
    readings, settle = schedule_from_config(
        'q', {'kind': 'isometric', 'x_m': [0, 0.01, 0.01], 'voltage_v': [0, 1, 1]})
    seq = Sequencer('q', readings, settle)
    seq.start(0.0)
    seq.tick(0.5, Measurement(1999.0, 0.0, 0.0))
    assert seq.phase == Phase.ABORTED and 'out of range' in seq.reason


def _records(cfg: dict, record_exchange_s: float, lag_ticks: int) -> tuple[list, list, list]:
    """Run a step-response schedule; the load cell's samples (force = 10 t N, 1 kHz) reach the
    sequencer ``lag_ticks`` ticks after their stamp (0: at the tick that ends their exchange,
    as the lock-step chain delivers them)."""
    readings, settle = schedule_from_config('s', cfg)
    seq = Sequencer('s', readings, settle, record_exchange_s=record_exchange_s)
    seq.start(0.0)
    t, cmd = 0.0, seq.tick(0.0, Measurement(0, 0, 0))
    pts, recs, periods, ticks = [], [], [], [0.0]
    while seq.running:
        t = round(min(t + 0.1, seq.next_event_s(t)), 9)    # coarse steps, events exact
        ticks.append(t)
        lo, hi = ticks[-2 - lag_ticks] if len(ticks) > 1 + lag_ticks else -1.0, \
            ticks[-1 - lag_ticks] if len(ticks) > lag_ticks else -1.0
        grid = np.round(np.arange(round(lo * 1e3) + 1, round(hi * 1e3) + 1) * 1e-3, 9)
        samples = [(float(ts), 10.0 * float(ts)) for ts in grid if ts > lo]
        cmd = seq.tick(t, Measurement(10 * t, 0.0, 0.0), samples)
        periods.append(cmd.sample_period_s)
        if cmd.point is not None:
            pts.append(cmd.point)
        if cmd.record is not None:
            recs.append(cmd.record)
    return pts, recs, periods


STEPS = dict(STEP, x_m=[0.0, 0.0, 0.005], up={'u0_v': 1.0, 'step_v': 0.2, 'n': 2},
             down={'u0_v': 5.0, 'step_v': -0.2, 'n': 1})


@pytest.mark.parametrize(('record_exchange_s', 'lag_ticks'), [(0.0, 0), (0.01, 1), (0.05, 2),
                                                             (0.0, 1)])
def test_step_response_records_1khz_on_exact_grid(record_exchange_s: float,
                                                  lag_ticks: int) -> None:
    pts, recs, periods = _records(STEPS, record_exchange_s, lag_ticks)
    assert len(pts) == 3 and len(recs) == 3
    for p, r in zip(pts, recs, strict=True):
        assert r.reading == p.reading and r.point == p
        assert len(r.samples) == 1000
        # sample i is the reading stamped t_step + i ms, whenever it arrived
        np.testing.assert_allclose(r.samples, 10 * (r.t_step_s + 1e-3 * np.arange(1000)),
                                   atol=1e-6)
        np.testing.assert_allclose(p.t_s - r.t_step_s, 1.0, atol=1e-9)
    assert max(periods) == 0.001 and min(periods) == 0.0      # samples asked for in records


def test_record_missing_samples_hold_the_last() -> None:
    readings, settle = schedule_from_config('s', dict(STEPS, x_m=[0.0, 0.0, 0.005],
                                                      up={'u0_v': 1.0, 'step_v': 0.2, 'n': 1},
                                                      down={'u0_v': 5.0, 'step_v': -0.2,
                                                            'n': 0}))
    seq = Sequencer('s', readings, settle, record_exchange_s=0.01)
    seq.start(0.0)
    t = 0.0
    recs = []
    while seq.running and t < 100:
        t = round(min(t + 0.01, seq.next_event_s(t)), 9)
        ms = np.round(np.arange(round(t * 1e3) - 9, round(t * 1e3) + 1) * 1e-3, 9)
        samples = [(float(s), 1.0 if round(s * 1e3) % 7 else float('nan')) for s in ms]
        samples = [(s, f) for s, f in samples if f == f]          # every 7th sample dropped
        cmd = seq.tick(t, Measurement(1.0, 0.0, 0.0), samples)
        if cmd.record is not None:
            recs.append(cmd.record)
    assert len(recs) == 1 and len(recs[0].samples) == 1000
    assert all(v == 1.0 for v in recs[0].samples)


def test_sequencer_resumed_settles_at_the_restart_reading() -> None:
    readings, settle = schedule_from_config('iso', QUICK_ISO)
    k = next(i for i, r in enumerate(readings) if r.series == 1)
    seq = Sequencer('iso', readings, settle, start_index=k)
    seq.start(0.0)
    cmd = seq.tick(0.0, Measurement(0, 0, 0))
    assert cmd.load_value == readings[k].load_value and cmd.voltage_v == readings[k].voltage_v
    t, pts = 0.0, []
    while seq.running:
        t = round(seq.next_event_s(t), 9)
        c = seq.tick(t, Measurement(10.0, readings[seq.index].load_value, 0.0))
        if c.point is not None:
            pts.append(c.point)
    assert [p.reading for p in pts] == readings[k:]
    assert seq.total_s == pytest.approx(settle + 3.0 * (len(readings) - k))
    with pytest.raises(ParameterError):
        Sequencer('iso', readings, settle, start_index=len(readings))
