"""The node executables of pam_bench and the module each runs: the one list of them.

Imports nothing, so that ``setup.py`` reads it without importing the package
(``config.nodes`` builds the node table on it).
"""

__all__ = ['EXECUTABLES']

EXECUTABLES = {
    'sim_clock': 'pam_bench.nodes.sim_clock',
    'valve_sim': 'pam_bench.nodes.valve_sim',
    'muscle_sim': 'pam_bench.nodes.muscle_sim',
    'loading_servo_sim': 'pam_bench.nodes.loading_servo_sim',
    'load_cell_sim': 'pam_bench.nodes.load_cell_sim',
    'encoder_sim': 'pam_bench.nodes.encoder_sim',
    'sequencer': 'pam_bench.nodes.sequencer',
    'torque_servo': 'pam_bench.nodes.torque_servo',
    'recorder': 'pam_bench.nodes.recorder',
    'daq_modbus': 'pam_bench.nodes.daq_modbus',
    'servo_canopen': 'pam_bench.nodes.servo_canopen',
}
"""Executable (console script) -> module with its ``main``."""
