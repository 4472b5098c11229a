"""A braided-pneumatic-actuator force law of the Hunt-Graber-Quinn kind, as a pam_bench plug-in.

After A. Hunt, A. Graber-Tilton and R. Quinn, "Modeling length effects of braided pneumatic
actuators", ASME IDETC 2017: the actuator's pressure as a function of its strain and force,
with a tangent that grows without bound as the strain nears a largest strain, which itself
falls as the load grows, and a term linear in the force:

    P(F, k) = a0 + a1 tan(a2 (k / (k_max + a4 F) + a3)) + a5 F

with gauge pressure P (Pa), strain (contraction ratio) k = x / l0, force F (N). pam_bench asks
for the force at a pressure and contraction, so the law is solved for F: P(F, k) grows with F
(a4 <= 0, a5 > 0), and F is found by bisection on [0, ``F_MAX_N``]; where even F = 0 needs
more pressure than p, the muscle is slack (F = 0). The defaults are illustrative values for a
muscle of 004's size (about 1500 N at 0.6 MPa and k = 0), not the paper's fitted ones.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw
from pam_bench.vocabulary.params import field

__all__ = ['HuntGraberQuinnParams', 'force', 'LAW', 'F_MAX_N']

F_MAX_N = 1.0e4
"""Upper end of the bisection, N."""
ITERATIONS = 60


@dataclasses.dataclass
class HuntGraberQuinnParams:
    """The law's parameters (module docstring)."""

    a0_pa: float = field(2.0e4, 'Pa', 'pressure at zero force and strain', 0.0, 2.0e5)
    a1_pa: float = field(1.5e5, 'Pa', 'scale of the tangent term', 1.0e3, 1.0e6)
    a2: float = field(math.pi / 2, '-', 'argument scale of the tangent', 0.5, 3.0)
    a3: float = field(0.0, '-', 'argument offset of the tangent', -0.5, 0.5)
    a4_per_n: float = field(-1.0e-4, '1/N', 'fall of the largest strain per newton', -1.0e-3,
                            0.0)
    k_max: float = field(0.30, '-', 'largest strain at zero force', 0.05, 0.5)
    a5_pa_per_n: float = field(387.0, 'Pa/N', 'pressure per newton of force', 1.0, 1.0e4)


def _pressure(th: np.ndarray, f: np.ndarray, k: np.ndarray) -> np.ndarray:
    a0, a1, a2, a3, a4, kmax, a5 = th
    arg = a2 * (k / np.maximum(kmax + a4 * f, 1e-6) + a3)
    return a0 + a1 * np.tan(np.clip(arg, -1.5, 1.5)) + a5 * f


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """F(p, x) of the law, N (module docstring); p in Pa, x in m, l0 in m."""
    p, k = np.broadcast_arrays(np.asarray(p, float), np.asarray(x, float) / l0)
    lo = np.zeros(p.shape)
    hi = np.full(p.shape, F_MAX_N)
    for _ in range(ITERATIONS):
        mid = 0.5 * (lo + hi)
        above = _pressure(th, mid, k) > p
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    f = 0.5 * (lo + hi)
    return np.where(_pressure(th, np.zeros(p.shape), k) >= p, 0.0, f)


LAW = ForceLaw.from_settings('hunt_graber_quinn', 'Hunt, Graber-Tilton and Quinn 2017',
                             HuntGraberQuinnParams, force)
"""The entry point ``pam_bench.muscle_laws: hunt_graber_quinn``."""
