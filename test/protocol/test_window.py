"""The reading window: the mean of the samples of the last window inside the band, what was
left out, fixed memory; and a noise burst that starts exactly at a reading instant."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.runner import Runner
from pam_bench.protocol.schedules import Direction, Reading
from pam_bench.protocol.sequencer import Phase, Sequencer
from pam_bench.protocol.settings import RunnerSettings
from pam_bench.protocol.window import SampleWindow


def _ms(k: int) -> float:
    return k * 1e-3


@pytest.mark.parametrize('window_s, band, mean, n, left_out', [
    (0.005, (-math.inf, math.inf), (6 + 7 + 8 + 9 + 10) / 5, 5, 0),   # (5, 10] ms
    (0.0005, (-math.inf, math.inf), 10.0, 1, 0),      # shorter than the period: the last one
    (0.005, (-math.inf, 8.5), (6 + 7 + 8) / 3, 3, 2),
    (0.005, (100.0, 200.0), -1.0, 0, 5),              # none in band: the latest given
])
def test_mean_of_the_window_in_band(window_s: float, band: tuple[float, float], mean: float,
                                    n: int, left_out: int) -> None:
    w = SampleWindow(keep_s=1.0)
    w.add([(_ms(k), float(k)) for k in range(11)])         # value k at k ms
    got = w.average(_ms(10), window_s, -1.0, band)
    np.testing.assert_allclose(got.value, mean, rtol=0, atol=1e-12)
    assert (got.n, len(got.outliers)) == (n, left_out)


def test_samples_after_the_instant_are_not_in_its_window() -> None:
    w = SampleWindow()
    w.add([(_ms(k), float(k)) for k in range(20)])
    assert w.average(_ms(10), 0.002, 0.0).value == pytest.approx(9.5)


def test_memory_stays_bounded() -> None:
    w = SampleWindow(keep_s=0.1)
    for k in range(0, 100_000, 100):
        w.add([(_ms(k + i), 1.0) for i in range(100)])
    assert len(w) <= 101


FORCE_N = 0.8        # a small characteristic, as the one the bad sample spoiled
BURST_N = 129.0


def _run(burst: list[float], outliers: str = 'report', band: bool = True, tick_ms: int = 1
         ) -> tuple[list, list[str], Sequencer]:
    """Two isometric readings (0.3 s dwell, 50 ms window) fed 1 kHz samples, the runner
    ticked every ``tick_ms``; ``burst``: sim times (s) whose force sample is 129 N."""
    readings = [Reading('isometric', 0, k, Direction.UP, 0.0, 1.0 + k, 1.0 + k,
                        LoadMode.POSITION, 0.0, 0.3, window_s=0.05) for k in range(2)]
    rules = '[{input: force, low: -50.0, high: 50.0, resume_after_s: 0.1}]' if band else ''
    run = Runner(RunnerSettings(suspenders_yaml=rules, reading_outliers=outliers),
                 lockstep=True)
    core = Sequencer('iso', readings, settle_s=0.1)
    run.load(core)
    rng = np.random.default_rng(1)
    points, notes = [], []
    for k in range(3000):
        t = _ms(k)
        f = BURST_N if any(abs(t - b) < 1e-9 for b in burst) else \
            FORCE_N + 0.01 * rng.standard_normal()
        run.measured('force', f, t)
        run.measured('contraction', 0.0002, t)
        run.measured('pressure', 1e5, t)
        if k % tick_ms:
            continue
        tick = run.tick(t)
        notes += [n.text for n in tick.notes]
        if tick.point is not None:
            points.append(tick.point)
        if core.phase == Phase.DONE:
            break
    return points, notes, core


def test_a_burst_at_the_reading_instant_suspends_and_the_reading_is_taken_again() -> None:
    """The bad sample is the latest at the reading's tick: the suspenders see it and hold
    the run; the reading is dwelt again once the force is back in band."""
    clean, _, _ = _run([])
    instant = clean[0].t_s
    points, notes, core = _run([instant])
    assert core.phase == Phase.DONE and len(points) == 2
    assert any(n.startswith('protocol suspended: force 129') for n in notes), notes
    assert points[0].t_s > instant + 0.1                 # suspended, then a whole dwell again
    assert all(abs(p.measurement.force_n - FORCE_N) < 0.01 for p in points)


@pytest.mark.parametrize('before_ms', [1, 5, 9])
def test_a_burst_inside_the_window_is_left_out_and_reported(before_ms: int) -> None:
    """Ticked every 10 ms (a sequencer slower than its load cell), a burst between two ticks
    is in the reading's window but never the latest value: the window leaves it out."""
    clean, _, _ = _run([], tick_ms=10)
    instant = clean[0].t_s
    points, notes, _ = _run([instant - _ms(before_ms)], tick_ms=10)
    p = points[0]
    assert p.t_s == instant
    assert p.outliers == (('force', pytest.approx(instant - _ms(before_ms)), BURST_N),)
    assert p.window_n == 49                       # 50 samples in (t - 50 ms, t], one left out
    np.testing.assert_allclose(p.measurement.force_n, clean[0].measurement.force_n,
                               atol=0.005)
    np.testing.assert_allclose(p.measurement.force_n, FORCE_N, atol=0.01)
    assert any('1 sample(s) of its 50 ms window outside the band' in n and '129 N' in n
               for n in notes), notes


def test_without_a_band_the_burst_is_averaged_in() -> None:
    clean, _, _ = _run([], band=False, tick_ms=10)
    points, notes, _ = _run([clean[0].t_s - _ms(5)], band=False, tick_ms=10)
    shift = points[0].measurement.force_n - clean[0].measurement.force_n
    np.testing.assert_allclose(shift, (BURST_N - FORCE_N) / 50, atol=0.01)
    assert points[0].outliers == () and not any('window' in n for n in notes)


def test_left_out_samples_can_suspend_the_run() -> None:
    clean, _, _ = _run([], tick_ms=10)
    instant = clean[0].t_s
    burst = [instant - _ms(i) for i in range(1, 10)]          # between the last two ticks
    points, notes, core = _run(burst, outliers='suspend', tick_ms=10)
    assert points[0].window_n == 41 and len(points[0].outliers) == 9
    np.testing.assert_allclose(points[0].measurement.force_n, FORCE_N, atol=0.01)
    assert any(n.startswith('protocol suspended: reading isometric') for n in notes), notes
    assert core.phase == Phase.DONE and len(points) == 2
    assert points[1].t_s > clean[1].t_s + 0.09        # held suspended for resume_after_s
