"""The CiA 402 power state machine and the drive's units."""

from __future__ import annotations

import pytest

from pam_bench.buses.cia402 import (
    CONTROLWORD,
    STATUSWORD,
    Command,
    DriveScale,
    State,
    command_towards,
    next_state,
    state_of,
)

S = State
C = CONTROLWORD


@pytest.mark.parametrize('state, cw, prev, after', [
    (S.SWITCH_ON_DISABLED, C[Command.SHUTDOWN], 0, S.READY_TO_SWITCH_ON),
    (S.READY_TO_SWITCH_ON, C[Command.SWITCH_ON], 6, S.SWITCHED_ON),
    (S.SWITCHED_ON, C[Command.ENABLE_OPERATION], 7, S.OPERATION_ENABLED),
    (S.OPERATION_ENABLED, C[Command.SWITCH_ON], 15, S.SWITCHED_ON),      # disable operation
    (S.OPERATION_ENABLED, C[Command.SHUTDOWN], 15, S.READY_TO_SWITCH_ON),
    (S.OPERATION_ENABLED, C[Command.QUICK_STOP], 15, S.QUICK_STOP_ACTIVE),
    (S.OPERATION_ENABLED, C[Command.DISABLE_VOLTAGE], 15, S.SWITCH_ON_DISABLED),
    (S.QUICK_STOP_ACTIVE, C[Command.DISABLE_VOLTAGE], 2, S.SWITCH_ON_DISABLED),
    (S.FAULT, C[Command.FAULT_RESET], 0, S.SWITCH_ON_DISABLED),
    (S.FAULT, C[Command.FAULT_RESET], 0x80, S.FAULT),                   # no edge, no reset
    (S.FAULT, C[Command.ENABLE_OPERATION], 0, S.FAULT),
    (S.SWITCH_ON_DISABLED, C[Command.ENABLE_OPERATION], 0, S.SWITCH_ON_DISABLED),  # no skip
])
def test_transitions(state: State, cw: int, prev: int, after: State) -> None:
    assert next_state(state, cw, prev) == after


@pytest.mark.parametrize('state', list(State))
def test_every_statusword_decodes_to_its_state(state: State) -> None:
    assert state_of(STATUSWORD[state]) == state
    assert state_of(STATUSWORD[state] | 0x0210) == state     # other bits do not matter


@pytest.mark.parametrize('start, steps', [(S.SWITCH_ON_DISABLED, 3), (S.FAULT, 4),
                                          (S.QUICK_STOP_ACTIVE, 4), (S.SWITCHED_ON, 1)])
def test_the_master_reaches_operation_and_back(start: State, steps: int) -> None:
    state, prev = start, 0
    for _ in range(steps):
        cw = command_towards(state, operate=True)
        if cw == prev == C[Command.FAULT_RESET]:
            cw = C[Command.DISABLE_VOLTAGE]
        state, prev = next_state(state, cw, prev), cw
    assert state == S.OPERATION_ENABLED
    assert next_state(state, command_towards(state, operate=False), prev) == \
        S.READY_TO_SWITCH_ON                        # off: the power stage off, no fault


def test_drive_units_round_trip() -> None:
    s = DriveScale()
    for permille in (-1000, -37, 0, 1, 250, 1000):
        assert s.torque_permille(s.force_of_permille(permille)) == permille
    # 004's bench: 1000 per mille = 1.27 N m at the motor = 1.27 * 70 / 0.03183 N at the belt
    assert s.force_of_permille(1000) == pytest.approx(1.27 * 70.0 / (0.06366 / 2), rel=1e-12)
    for counts in (-65536, -1, 0, 12345):
        assert s.counts(s.angle_of(counts)) == counts
