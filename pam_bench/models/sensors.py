"""Load cell and encoder of the 004 bench (section 2.1).

Load cell (strain gauge): range +-2 kN mapped to +-10 V, read by a 16-bit converter over
+-10 V, so one count is 4000 N / 2^16 = 0.061 N. Measured force
F_m = q(clip(F + n, -F_r, F_r)), n ~ N(0, sigma^2) from a seeded generator, q = rounding to
the count. Beyond the range the reading saturates and ``saturated`` is set.

Encoder (absolute optical, 16 bits per revolution): resolution 2 pi / 2^16 = 9.59e-5 rad, which
on the 63.66 mm pulley is 3.05e-6 m of belt (004 states 0.005 mm). The angle is quantised to the
count and tracked over several turns (multi-turn count, as a driver unwraps it).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from pam_bench.models.constants import LOAD_CELL_RANGE_N
from pam_bench.models.errors import ModelError
from pam_bench.vocabulary.params import field

__all__ = ['LoadCellParams', 'LoadCellModel', 'EncoderParams', 'EncoderModel']


@dataclasses.dataclass
class LoadCellParams:
    """Parameters of ``LoadCellModel``."""

    range_n: float = field(LOAD_CELL_RANGE_N, 'N', 'measuring range +-F_r', 1.0, 1.0e6)
    output_range_v: float = field(10.0, 'V', 'analog output +-U_r at +-F_r', 0.1, 100.0)
    adc_bits: int = field(16, 'bit', 'resolution of the converter over +-U_r', 1, 32)
    noise_std_n: float = field(0.2, 'N', 'standard deviation of the Gaussian noise',
                               0.0, 1.0e4)
    noise: bool = field(True, '-', 'add noise')
    quantise: bool = field(True, '-', 'round to the converter count')


class LoadCellModel:
    """Strain-gauge load cell with a 16-bit converter and seeded noise."""

    def __init__(self, params: LoadCellParams | None = None, seed: int = 0) -> None:
        self.p = params or LoadCellParams()
        self.rng = np.random.default_rng(seed)
        self.saturated = False

    @property
    def count_n(self) -> float:
        """Force of one converter count, N."""
        return 2.0 * self.p.range_n / 2 ** self.p.adc_bits

    def voltage(self, force_n: float) -> float:
        """Analog output for a force, V (clipped to the output range)."""
        f = min(max(force_n, -self.p.range_n), self.p.range_n)
        return f * self.p.output_range_v / self.p.range_n

    def measure_many(self, forces_n: Sequence[float] | np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
        """``measure`` of every force in order, in one batch: the same noise draws, the same
        rounding (numpy's is Python's, half to even), bit for bit. Returns (measured N,
        saturated), shapes (n,); ``saturated`` is left as the last sample leaves it.

        Raises:
            ModelError: a true force is not finite.
        """
        if len(forces_n) == 1:                    # one reading: the scalar path, cheaper
            one = self.measure(float(forces_n[0]))
            return np.array([one]), np.array([self.saturated])
        f = np.array(forces_n, dtype=float)
        if not np.isfinite(f).all():
            raise ModelError(f'load cell input {f[~np.isfinite(f)][0]!r} is not finite')
        if self.p.noise and self.p.noise_std_n > 0.0:
            f = f + self.rng.normal(0.0, self.p.noise_std_n, f.shape[0])
        sat = np.abs(f) >= self.p.range_n
        if len(f):
            self.saturated = bool(sat[-1])
        f = np.minimum(np.maximum(f, -self.p.range_n), self.p.range_n)
        if self.p.quantise:
            q = self.count_n
            f = np.round(f / q) * q
        return f, sat

    def measure(self, force_n: float) -> float:
        """Measured force for a true tension, N.

        Raises:
            ModelError: the true force is not finite.
        """
        if not math.isfinite(force_n):
            raise ModelError(f'load cell input {force_n!r} is not finite')
        f = force_n
        if self.p.noise and self.p.noise_std_n > 0.0:
            f += float(self.rng.normal(0.0, self.p.noise_std_n))
        self.saturated = abs(f) >= self.p.range_n
        f = min(max(f, -self.p.range_n), self.p.range_n)
        if self.p.quantise:
            q = self.count_n
            f = round(f / q) * q
        return f


@dataclasses.dataclass
class EncoderParams:
    """Parameters of ``EncoderModel``."""

    bits_per_rev: int = field(16, 'bit', 'counts per revolution as a power of two', 1, 32)
    quantise: bool = field(True, '-', 'round to the count')


class EncoderModel:
    """Absolute encoder on the pulley shaft, multi-turn tracked."""

    def __init__(self, params: EncoderParams | None = None) -> None:
        self.p = params or EncoderParams()
        self._last: float | None = None

    @property
    def resolution_rad(self) -> float:
        """Angle of one count, rad."""
        return 2.0 * math.pi / 2 ** self.p.bits_per_rev

    def measure(self, angle_rad: float, dt_s: float) -> tuple[float, float]:
        """Quantised angle (rad) and its finite-difference rate over ``dt_s`` (rad/s).

        Raises:
            ModelError: the angle is not finite.
        """
        if not math.isfinite(angle_rad):
            raise ModelError(f'encoder input {angle_rad!r} is not finite')
        a = angle_rad
        if self.p.quantise:
            q = self.resolution_rad
            a = round(a / q) * q
        rate = 0.0 if self._last is None or dt_s <= 0.0 else (a - self._last) / dt_s
        self._last = a
        return a, rate
