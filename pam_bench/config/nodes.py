"""The node table: every node a scene can run, its executable, class, role and settings.

One list for everything that needs to know the nodes: the scene loader (names, settings), the
bring-up (what to start and in which order, which nodes step in lock-step), the emulator
(the devices, in the order they step within a wall-clock tick), the CLI and ``setup.py`` (the
executables, ``config.executables``).
"""

from __future__ import annotations

import dataclasses
import enum

from pam_bench.config.executables import EXECUTABLES
from pam_bench.config.settings import (
    ClockSettings,
    DaqModbusSettings,
    EncoderSettings,
    LoadCellSettings,
    LoadingServoSettings,
    MuscleSettings,
    RecorderSettings,
    SequencerSettings,
    ServoCanopenSettings,
    TorqueServoSettings,
    ValveSettings,
)
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import hint

__all__ = ['Role', 'NodeType', 'NODES', 'node', 'devices', 'controllers', 'SCENE_NODES',
           'EXECUTABLES', 'ground_truth_of', 'MEASURED']


class Role(enum.Enum):
    """What a node is on the bench."""

    CLOCK = 'clock'              # the lock-step master (simulation only)
    DEVICE = 'device'            # a simulated device; a driver on a real bench
    CONTROLLER = 'controller'    # reads the measured topics, commands the valves
    RECORDER = 'recorder'
    DRIVER = 'driver'            # a driver of real hardware on a field bus (wall clock only)


@dataclasses.dataclass(frozen=True)
class NodeType:
    """One node a scene can run.

    Attributes:
        executable: its console script (``config.executables``).
        cls: the node class in that module.
        role: what it is on the bench.
        settings: its settings dataclass (``config.settings``).
        channel: the muscle channel of a per-channel node (0: none).
    """

    executable: str
    cls: str
    role: Role
    settings: type
    channel: int = 0

    @property
    def module(self) -> str:
        """The module holding the class and its ``main``."""
        return EXECUTABLES[self.executable]

    @property
    def lockstep(self) -> bool:
        """Whether it steps in lock-step with the clock (everything but the clock and the
        drivers of real hardware)."""
        return self.role not in (Role.CLOCK, Role.DRIVER)


_D, _C = Role.DEVICE, Role.CONTROLLER
NODES: dict[str, NodeType] = {
    # devices, in the order they step within one wall-clock tick (bringup.emulator)
    'valve_1': NodeType('valve_sim', 'ValveSim', _D, ValveSettings, 1),
    'valve_2': NodeType('valve_sim', 'ValveSim', _D, ValveSettings, 2),
    'muscle_1': NodeType('muscle_sim', 'MuscleSim', _D, MuscleSettings, 1),
    'muscle_2': NodeType('muscle_sim', 'MuscleSim', _D, MuscleSettings, 2),
    'loading_servo': NodeType('loading_servo_sim', 'LoadingServoSim', _D, LoadingServoSettings,
                              1),
    'load_cell_1': NodeType('load_cell_sim', 'LoadCellSim', _D, LoadCellSettings, 1),
    'load_cell_2': NodeType('load_cell_sim', 'LoadCellSim', _D, LoadCellSettings, 2),
    'encoder': NodeType('encoder_sim', 'EncoderSim', _D, EncoderSettings),
    'sequencer': NodeType('sequencer', 'SequencerNode', _C, SequencerSettings, 1),
    'torque_servo': NodeType('torque_servo', 'TorqueServoNode', _C, TorqueServoSettings),
    'recorder': NodeType('recorder', 'Recorder', Role.RECORDER, RecorderSettings),
    'sim_clock': NodeType('sim_clock', 'SimClock', Role.CLOCK, ClockSettings),
    'daq_modbus': NodeType('daq_modbus', 'DaqModbusNode', Role.DRIVER, DaqModbusSettings),
    'servo_canopen': NodeType('servo_canopen', 'ServoCanopenNode', Role.DRIVER,
                              ServoCanopenSettings, 1),
}
"""Node name -> what it is. The executables' default node names are these names."""

SCENE_NODES = [n for n, t in NODES.items() if t.role not in (Role.CLOCK, Role.DRIVER)]
"""Nodes a scene may name (the clock comes with every lock-step run; the bus drivers with
``run --wallclock --buses``)."""


def node(name: str) -> NodeType:
    """The node called ``name``.

    Raises:
        ParameterError: no such node (names the nearest).
    """
    try:
        return NODES[name]
    except KeyError:
        raise ParameterError(f'unknown node {name!r} ({hint(name, NODES)})') from None


def devices(names: list[str]) -> list[str]:
    """The devices among ``names``, in the order they step within a wall-clock tick."""
    return [n for n, t in NODES.items() if t.role == Role.DEVICE and n in names]


def controllers(names: list[str]) -> list[str]:
    """The controllers among ``names`` (sequencer, torque servo), in table order."""
    return [n for n, t in NODES.items() if t.role == Role.CONTROLLER and n in names]


def ground_truth_of(name: str, names: list[str]) -> list[str]:
    """The simulated devices among ``names`` whose ground truth (``sim/`` topics) the
    simulated device ``name`` reads: a real device that replaces one of them publishes none,
    so ``name`` cannot run beside it (``run --external``)."""
    ch = NODES[name].channel
    muscles = [n for n in names if n.startswith('muscle_')]
    needs = {'valve_sim': [f'muscle_{ch}'], 'muscle_sim': [f'valve_{ch}', 'loading_servo'],
             'load_cell_sim': [f'muscle_{ch}'], 'encoder_sim': ['loading_servo'],
             'loading_servo_sim': muscles}.get(NODES[name].executable, [])
    return [n for n in needs if n in names]


MEASURED = {'valve_1': 'valve_1/pressure', 'valve_2': 'valve_2/pressure',
            'load_cell_1': 'load_cell_1/force', 'load_cell_2': 'load_cell_2/force',
            'encoder': 'encoder/joint_state', 'loading_servo': 'loading_servo/state',
            'muscle_1': '', 'muscle_2': ''}
"""What each device publishes of the driver contract (``config.drivers``; a muscle none)."""
