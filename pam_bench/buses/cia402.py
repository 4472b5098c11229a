"""The CiA 402 drive profile: the power state machine, its words, and the drive's units.

The state machine of CiA 402 (IEC 61800-7-201) as a pure table, used on both sides of the bus:
the emulated drive (``twin.buses``) steps it on each controlword it receives, the driver
(``buses.canopen_drive``) reads the statusword and sends the controlword that leads towards
the state it wants (``command_towards``)::

    SWITCH_ON_DISABLED --shutdown--> READY_TO_SWITCH_ON --switch on--> SWITCHED_ON
        --enable operation--> OPERATION_ENABLED --quick stop--> QUICK_STOP_ACTIVE
    any state --fault--> FAULT_REACTION_ACTIVE -> FAULT --fault reset (bit 7 rising)-->
        SWITCH_ON_DISABLED;   disable voltage: back to SWITCH_ON_DISABLED

Objects used (CiA 402 numbering): controlword 0x6040, statusword 0x6041, modes of operation
0x6060 and its display 0x6061, position actual 0x6064, target torque 0x6071, torque actual
0x6077, target position 0x607A, motor rated torque 0x6076 (mN m).

Units (``DriveScale``): the bench's loading servo (004) is a motor with a gear of ratio i and a
pulley of pitch radius r that pulls on the muscle. A force set value F (N, muscle tension)
is a motor torque T = F r / i, sent as per mille of the rated torque (0x6071, cyclic
synchronous torque, mode 10); a contraction set value x (m) is a pulley angle x / r, sent in
counts of the output encoder, 2^bits per revolution (0x607A, cyclic synchronous position,
mode 8); "off" disables the operation (shutdown: the power stage off, the pulley free).
"""

from __future__ import annotations

import enum

from pam_bench.models.loading_servo.units import DriveScale

__all__ = ['State', 'Command', 'CONTROLWORD', 'STATUSWORD', 'next_state', 'state_of',
           'command_towards', 'DriveScale', 'MODE_CSP', 'MODE_CST', 'OD']
# DriveScale lives with the drive's model (models.loading_servo.units); named here too


class State(enum.Enum):
    """The power states of CiA 402."""

    NOT_READY_TO_SWITCH_ON = 'not ready to switch on'
    SWITCH_ON_DISABLED = 'switch on disabled'
    READY_TO_SWITCH_ON = 'ready to switch on'
    SWITCHED_ON = 'switched on'
    OPERATION_ENABLED = 'operation enabled'
    QUICK_STOP_ACTIVE = 'quick stop active'
    FAULT_REACTION_ACTIVE = 'fault reaction active'
    FAULT = 'fault'


class Command(enum.Enum):
    """The device control commands a controlword carries."""

    SHUTDOWN = 'shutdown'
    SWITCH_ON = 'switch on'
    ENABLE_OPERATION = 'enable operation'
    DISABLE_VOLTAGE = 'disable voltage'
    QUICK_STOP = 'quick stop'
    FAULT_RESET = 'fault reset'


CONTROLWORD = {Command.SHUTDOWN: 0x0006, Command.SWITCH_ON: 0x0007,
               Command.ENABLE_OPERATION: 0x000F, Command.DISABLE_VOLTAGE: 0x0000,
               Command.QUICK_STOP: 0x0002, Command.FAULT_RESET: 0x0080}
"""The controlword that sends each command (bits 0..3 and 7)."""

STATUSWORD = {State.NOT_READY_TO_SWITCH_ON: 0x0000, State.SWITCH_ON_DISABLED: 0x0040,
              State.READY_TO_SWITCH_ON: 0x0021, State.SWITCHED_ON: 0x0023,
              State.OPERATION_ENABLED: 0x0027, State.QUICK_STOP_ACTIVE: 0x0007,
              State.FAULT_REACTION_ACTIVE: 0x000F, State.FAULT: 0x0008}
"""The statusword bits (0..3, 5, 6) a drive shows in each state."""

_DECODE = ((0x4F, 0x00, State.NOT_READY_TO_SWITCH_ON), (0x4F, 0x40, State.SWITCH_ON_DISABLED),
           (0x6F, 0x21, State.READY_TO_SWITCH_ON), (0x6F, 0x23, State.SWITCHED_ON),
           (0x6F, 0x27, State.OPERATION_ENABLED), (0x6F, 0x07, State.QUICK_STOP_ACTIVE),
           (0x4F, 0x0F, State.FAULT_REACTION_ACTIVE), (0x4F, 0x08, State.FAULT))

MODE_CSP = 8
"""Modes of operation: cyclic synchronous position."""
MODE_CST = 10
"""Modes of operation: cyclic synchronous torque."""

OD = {'controlword': 0x6040, 'statusword': 0x6041, 'modes_of_operation': 0x6060,
      'modes_display': 0x6061, 'position_actual': 0x6064, 'target_torque': 0x6071,
      'rated_torque': 0x6076, 'torque_actual': 0x6077, 'target_position': 0x607A}
"""Index of each CiA 402 object the bench uses."""


def state_of(statusword: int) -> State:
    """The state a statusword shows."""
    for mask, value, state in _DECODE:
        if statusword & mask == value:
            return state
    return State.NOT_READY_TO_SWITCH_ON


def _command_of(controlword: int, previous: int) -> Command | None:
    """The command a controlword gives (a fault reset is the rising edge of bit 7)."""
    if controlword & 0x80 and not previous & 0x80:
        return Command.FAULT_RESET
    if controlword & 0x02 == 0:
        return Command.DISABLE_VOLTAGE
    if controlword & 0x06 == 0x02:
        return Command.QUICK_STOP
    if controlword & 0x07 == 0x06:
        return Command.SHUTDOWN
    if controlword & 0x0F == 0x07:
        return Command.SWITCH_ON
    if controlword & 0x0F == 0x0F:
        return Command.ENABLE_OPERATION
    return None


_NEXT = {
    (State.SWITCH_ON_DISABLED, Command.SHUTDOWN): State.READY_TO_SWITCH_ON,
    (State.READY_TO_SWITCH_ON, Command.SWITCH_ON): State.SWITCHED_ON,
    (State.READY_TO_SWITCH_ON, Command.DISABLE_VOLTAGE): State.SWITCH_ON_DISABLED,
    (State.READY_TO_SWITCH_ON, Command.QUICK_STOP): State.SWITCH_ON_DISABLED,
    (State.SWITCHED_ON, Command.ENABLE_OPERATION): State.OPERATION_ENABLED,
    (State.SWITCHED_ON, Command.SHUTDOWN): State.READY_TO_SWITCH_ON,
    (State.SWITCHED_ON, Command.DISABLE_VOLTAGE): State.SWITCH_ON_DISABLED,
    (State.SWITCHED_ON, Command.QUICK_STOP): State.SWITCH_ON_DISABLED,
    (State.OPERATION_ENABLED, Command.SWITCH_ON): State.SWITCHED_ON,   # disable operation
    (State.OPERATION_ENABLED, Command.SHUTDOWN): State.READY_TO_SWITCH_ON,
    (State.OPERATION_ENABLED, Command.DISABLE_VOLTAGE): State.SWITCH_ON_DISABLED,
    (State.OPERATION_ENABLED, Command.QUICK_STOP): State.QUICK_STOP_ACTIVE,
    (State.QUICK_STOP_ACTIVE, Command.DISABLE_VOLTAGE): State.SWITCH_ON_DISABLED,
    (State.QUICK_STOP_ACTIVE, Command.ENABLE_OPERATION): State.OPERATION_ENABLED,
    (State.FAULT, Command.FAULT_RESET): State.SWITCH_ON_DISABLED,
}


def next_state(state: State, controlword: int, previous: int = 0) -> State:
    """The state a drive in ``state`` goes to on ``controlword`` (``previous``: the one
    before, for the fault reset's edge); a command the state does not take leaves it."""
    command = _command_of(controlword, previous)
    if command is None:
        return state
    return _NEXT.get((state, command), state)


def command_towards(state: State, operate: bool) -> int:
    """The controlword that moves a drive in ``state`` one transition towards operation
    enabled (``operate``) or towards ready to switch on, power stage off (not ``operate``):
    a fault is reset, a quick stop left through switch on disabled."""
    if state in (State.FAULT, State.FAULT_REACTION_ACTIVE):
        return CONTROLWORD[Command.FAULT_RESET]
    if state == State.QUICK_STOP_ACTIVE:
        return CONTROLWORD[Command.DISABLE_VOLTAGE]
    if not operate:
        return CONTROLWORD[Command.SHUTDOWN]
    if state in (State.SWITCH_ON_DISABLED, State.NOT_READY_TO_SWITCH_ON):
        return CONTROLWORD[Command.SHUTDOWN]
    if state == State.READY_TO_SWITCH_ON:
        return CONTROLWORD[Command.SWITCH_ON]
    return CONTROLWORD[Command.ENABLE_OPERATION]
