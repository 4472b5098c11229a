"""Inverse muscle models the torque servo feeds forward, loaded from the extraction's YAML.

Dynamic (004 Eq. 2 around the working point (u0, F_a0(x))): with y = F - F_a0(x) and
v = u - u0, y'' + b(x) y' + c(x) y = d(x) v, so the voltage that makes the force follow
F*(t) is

    u = u0 + (F*'' + b(x) F*' + c(x) (F* - F_a0(x))) / d(x)

Static (isometric surface, 004 section 2.2): F = k(x) u + F0(x) on the hysteresis midline, so

    u = (F* - F0(x)) / k(x)

b, c, d, F_a0, k, F0 are polynomials (coefficients low to high) in the centred and scaled
contraction z = (x - x_mid) / x_half, x in m. Units: F in N, F' in N/s, F'' in N/s^2, u in V.
Both clamp u to the valve's [u_min, u_max] and x to the identified range (no extrapolation).
"""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Any

import numpy as np

from pam_bench.models.errors import ModelError
from pam_bench.vocabulary.errors import InputError
from pam_bench.vocabulary.yaml_io import load_yaml, read_text

__all__ = ['Poly', 'InverseModel']


@dataclasses.dataclass(frozen=True)
class Poly:
    """p(z), z = (x - x_mid_m) / x_half_m, coefficients low to high."""

    coefficients: tuple[float, ...]
    x_mid_m: float
    x_half_m: float

    def __call__(self, x_m: float) -> float:
        """The polynomial at ``x_m`` (m), z clamped to the fitted range [-1, 1].

        Horner's rule in floats, the operations of numpy's ``polyval`` in its order (the
        same bits, ``test_inverse``; numpy's costs about 2 us a call, and the servo makes
        eight calls per 1 ms exchange)."""
        z = (x_m - self.x_mid_m) / self.x_half_m if self.x_half_m else 0.0
        z = min(max(z, -1.0), 1.0)
        c = self.coefficients
        acc = c[-1] + z * 0.0
        for i in range(len(c) - 2, -1, -1):
            acc = c[i] + acc * z
        return float(acc)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Poly:
        """Read the mapping ``inverse_model.yaml`` holds for one coefficient."""
        return cls(tuple(float(c) for c in d['coefficients_low_to_high']),
                   float(d['x_mid_m']), float(d['x_half_range_m']))


@dataclasses.dataclass(frozen=True)
class InverseModel:
    """Dynamic and static inverse of one muscle (see the module docstring)."""

    b: Poly
    c: Poly
    d: Poly
    f_a0: Poly
    u0_v: float
    k: Poly
    f0: Poly
    u_min_v: float = 0.0
    u_max_v: float = 10.0

    def _clamp(self, u: float) -> float:
        return min(max(u, self.u_min_v), self.u_max_v)

    def dynamic_voltage(self, force_n: float, rate_n_s: float, accel_n_s2: float,
                        contraction_m: float) -> float:
        """U (V) for the desired F*, F*', F*'' at contraction x (m)."""
        x = contraction_m
        d = self.d(x)
        if abs(d) < 1e-12:
            return self.static_voltage(force_n, x)
        return self._clamp(self.u0_v + (accel_n_s2 + self.b(x) * rate_n_s
                                        + self.c(x) * (force_n - self.f_a0(x))) / d)

    def forward_force(self, voltage_v: np.ndarray, period_s: float, contraction_m: float,
                      force_start_n: float) -> np.ndarray:
        """The identified forward model (004 Eq. 4 around the working point) driven by a
        recorded voltage at held x: y'' + b y' + c y = d (u - u0), F = F_a0(x) + y, integrated
        exactly under a zero-order hold (``models.lti``) from F = ``force_start_n`` at rest;
        N, shape of ``voltage_v`` (one sample per ``period_s``)."""
        from pam_bench.models.lti import second_order_matrices, zoh
        x = contraction_m
        a, b = second_order_matrices(self.b(x), self.c(x), self.d(x))
        ad, bd = zoh(a, b, period_s)
        state = np.array([force_start_n - self.f_a0(x), 0.0])
        out = np.empty(len(voltage_v))
        for i, u in enumerate(np.asarray(voltage_v, float)):
            out[i] = state[0]
            state = ad @ state + bd[:, 0] * (u - self.u0_v)
        return out + self.f_a0(x)

    def static_voltage(self, force_n: float, contraction_m: float) -> float:
        """U (V) that holds F* at contraction x (m) once settled."""
        k = self.k(contraction_m)
        if k <= 1e-9:
            return self.u_max_v if force_n > self.f0(contraction_m) else self.u_min_v
        return self._clamp((force_n - self.f0(contraction_m)) / k)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> InverseModel:
        """From the mapping written by ``pam-bench extract`` (inverse_model.yaml).

        Raises:
            ModelError: a key is missing or malformed.
        """
        try:
            dyn, sta = data['dynamic'], data['static']
            return cls(Poly.from_dict(dyn['b']), Poly.from_dict(dyn['c']),
                       Poly.from_dict(dyn['d']), Poly.from_dict(dyn['F_a0_N']),
                       float(dyn['u0_V']), Poly.from_dict(sta['k_N_per_V']),
                       Poly.from_dict(sta['F0_N']), float(data.get('u_min_V', 0.0)),
                       float(data.get('u_max_V', 10.0)))
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f'inverse model: missing or malformed entry ({exc})') from None

    @classmethod
    def load(cls, path: str | pathlib.Path) -> InverseModel:
        """Read an inverse_model.yaml.

        Raises:
            ModelError: unreadable file or malformed content.
        """
        try:
            data = load_yaml(read_text(pathlib.Path(path)), str(path))
        except InputError as exc:
            raise ModelError(f'inverse model {exc}') from None
        if not isinstance(data, dict):
            raise ModelError(f'inverse model {path}: not a mapping')
        return cls.from_dict(data)
