"""Thin rclpy nodes, one per simulated device or bench role: message <-> model."""

from __future__ import annotations

__all__ = ['base', 'driver_probe', 'encoder_sim', 'intra', 'load_cell_sim', 'loading_servo_sim',
           'muscle_sim', 'profiling', 'recorder', 'sequencer', 'sim_clock', 'torque_servo',
           'valve_sim']
