"""Figures of the 004 bench that several models, nodes and tools share (SI units).

Each is defined once here; a parameter dataclass uses it as its default and a node as the
default of its declared parameter, so a lab that changes its bench changes one line (or the
parameter in config/bench.yaml).
"""

from __future__ import annotations

__all__ = ['ATMOSPHERE_PA', 'PULLEY_PITCH_DIAMETER_M', 'LOAD_CELL_RANGE_N', 'SUB_STEP_S']

ATMOSPHERE_PA = 101325.0
"""Pa: standard atmosphere; ``valve_N/pressure`` is absolute, the models work in gauge."""

PULLEY_PITCH_DIAMETER_M = 0.06366
"""m: pitch diameter of the toothed-belt pulley (004: 63.66 mm), x = r theta with r = d / 2."""

LOAD_CELL_RANGE_N = 2000.0
"""N: measuring range +-F_r of the strain-gauge load cell (004: +-2 kN); the full scale."""

SUB_STEP_S = 0.005
"""s: default sub-step on which the valve's pressure samples, the muscle and the drive are
solved inside one exchange (a scene's ``sub_step_s``)."""

