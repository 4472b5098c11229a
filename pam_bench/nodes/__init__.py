"""The bench's nodes, one per simulated device or bench role: message <-> model."""

from __future__ import annotations

__all__ = ['bag_floor', 'driver_probe', 'encoder_sim', 'live_view', 'load_cell_sim',
           'loading_servo_sim', 'muscle_sim', 'recorder', 'sequencer', 'sim_clock',
           'torque_servo', 'valve_sim']
