"""Whether a bag calibration found the muscle: its residual per protocol against the noise.

A fit that stops is not a fit that found the muscle. The residual left per protocol is set
beside what the measurement itself scatters (``noise_levels``):

- forces (isometric readings, step records): the load cell's noise, estimated from the step
  records' settled tails (the standard deviation of the last quarter of each record about a
  straight line, the median over records), or from readings the bag holds twice at the same
  set values with nothing moved in between (the top and the bottom of a sweep: their
  difference over sqrt 2), whichever is larger; without either, the bench's load cell
  (``LoadCellParams.noise_std_n``);
- contractions (isotonic, isobaric): the encoder's resolution (one count, rad r) or the
  repeated readings, whichever is larger.

Beside the noise stands the replay's own floor (``FLOOR``): how far the replay is from the
time-stepped bench it stands for, at the true parameters and without noise (BENCHMARKS.md,
'Calibrating the bench to recordings'). A protocol is at the noise level
when its RMS is within ``NOISE_FACTOR`` times its noise, or within the floor, whichever is
larger. The fit is ``converged`` only when every protocol is; otherwise the verdict names the
protocols above and what to try.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.sensors import EncoderParams, LoadCellParams

__all__ = ['Verdict', 'noise_levels', 'verdict', 'NOISE_FACTOR', 'FLOOR', 'UNITS',
           'NOT_CONVERGED']

NOISE_FACTOR = 3.0
"""A residual within this many noise standard deviations is at the noise level."""
FLOOR: dict[str, float] = {'isometric': 0.1, 'isotonic': 0.05, 'isobaric': 0.05,
                           'step_records': 1.5}
"""The stepped replay's own error at the true parameters, rounded up (N or mm): the smallest
residual the fit can be asked for."""
UNITS = {'isometric': 'N', 'isotonic': 'mm', 'isobaric': 'mm', 'step_records': 'N'}
NOT_CONVERGED = 3
"""Exit code of ``pam-bench calibrate`` when the fit did not reach the noise level."""
TAIL_SHARE = 0.25


@dataclasses.dataclass(frozen=True)
class Verdict:
    """Per protocol: RMS, noise, tolerance (N or mm); whether all are at the noise level,
    the protocols that are not, and what to try."""

    converged: bool
    rms: dict[str, float]
    noise: dict[str, float]
    tolerance: dict[str, float]
    above: tuple[str, ...]
    advice: str

    def line(self) -> str:
        """The one line a user reads."""
        parts = ', '.join(f'{k} {self.rms[k]:.3g} {UNITS[k]} (noise level {self.tolerance[k]:.3g}'
                          f' {UNITS[k]})' for k in self.rms)
        if self.converged:
            return f'converged: every protocol at the noise level: {parts}'
        return f'not converged: {parts}; try {self.advice}'

    def as_dict(self) -> dict[str, Any]:
        """For JSON output and the overlay's header."""
        return dataclasses.asdict(self)


def _repeats(readings: Sequence[tuple[str, float, float, float]]) -> dict[str, list[float]]:
    """Differences of consecutive readings at the same kind, voltage and held value."""
    out: dict[str, list[float]] = {}
    for a, b in zip(readings[:-1], readings[1:], strict=True):
        if a[:3] == b[:3]:
            out.setdefault(a[0], []).append(b[3] - a[3])
    return out


def noise_levels(readings: Sequence[tuple[str, float, float, float]],
                 records: Sequence[tuple[float, float, float, float, np.ndarray]],
                 servo: LoadingServoParams | None = None) -> dict[str, float]:
    """The noise standard deviation per protocol kind present, N or mm (module docstring)."""
    tails = []
    for *_, samples in records:
        s = np.asarray(samples, float)
        tail = s[int(len(s) * (1.0 - TAIL_SHARE)):]
        if len(tail) >= 10:
            t = np.arange(len(tail))
            fit = np.polyfit(t, tail, 1)
            tails.append(float(np.std(tail - np.polyval(fit, t), ddof=2)))
    force = float(np.median(tails)) if tails else LoadCellParams().noise_std_n
    servo = servo or LoadingServoParams()
    count_m = servo.pitch_diameter_m / 2.0 * 2.0 * math.pi / 2 ** EncoderParams().bits_per_rev
    reps = _repeats(readings)
    out: dict[str, float] = {}
    kinds = {r[0] for r in readings} | ({'step_records'} if records else set())
    for kind in kinds:
        rep = reps.get(kind, [])
        spread = float(np.std(rep) / math.sqrt(2.0)) if len(rep) >= 3 else 0.0
        if kind in ('isometric', 'step_records'):
            out[kind] = max(force, spread)
        else:
            out[kind] = max(count_m / math.sqrt(12.0), spread) * 1e3
    return out


def verdict(rms: dict[str, float], noise: dict[str, float], hints: Sequence[str] = ()
            ) -> Verdict:
    """Whether every protocol's RMS is at the noise level (module docstring); ``hints``: what
    the fit saw that a user could change (a short grid, a parameter at a bound), said first."""
    tol = {k: max(NOISE_FACTOR * noise.get(k, 0.0), FLOOR.get(k, 0.0)) for k in rms}
    above = tuple(k for k in rms if not rms[k] <= tol[k])
    advice = '; '.join([*hints, 'more starts (--starts)', 'another law of the zoo (--law)'])
    return Verdict(not above and bool(rms), dict(rms), {k: noise.get(k, 0.0) for k in rms},
                   tol, above, advice)
