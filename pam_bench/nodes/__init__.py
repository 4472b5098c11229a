"""Thin rclpy nodes, one per simulated device or bench role: message <-> model."""

from __future__ import annotations

__all__ = ['base', 'cdr', 'core', 'driver_probe', 'encoder_sim', 'faults', 'intra',
           'load_cell_sim', 'loading_servo_sim', 'lockstep', 'messages', 'muscle_sim', 'params',
           'process', 'profiling', 'qos', 'recorder', 'sequencer', 'sim_clock', 'stats',
           'torque_servo', 'valve_sim', 'wallclock']
