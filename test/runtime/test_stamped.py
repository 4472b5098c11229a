"""Stamped messages built by filling rosidl's slots: the same objects and the same bytes as
rosidl's constructor and setters give."""

from __future__ import annotations

import array
from typing import Any

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from pam_bench_interfaces.msg import (
    DriveLaw,
    LoadCommand,
    MuscleSamples,
    MuscleState,
    PressureSamples,
    TorqueServoState,
    ValveCommand,
)
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import FluidPressure, Imu, JointState

from pam_bench.runtime.cdr import encoder
from pam_bench.runtime.messages import time_of
from pam_bench.runtime.stamped import _builder, stamped

T_NS = 1_234_567_890_123

CASES: list[tuple[type, str, dict[str, Any]]] = [
    (JointState, '', dict(name=['pulley'], position=[0.25], velocity=[-1.5])),
    (JointState, 'x', dict(name=['motor'], position=[1.0], velocity=[0.0], effort=[2.5])),
    (JointState, '', {}),
    (MuscleState, 'muscle_1', dict(pressure=3e5, force=120.5, contraction=0.01, volume=1e-5,
                                   stiffness=8000.0, friction_force=-0.4)),
    (MuscleSamples, 'muscle_1', dict(step=array.array('d', [0.005, 0.005]),
                                     force=[1.0, 2.0], contraction=[0.0, 1e-3], record=True)),
    (PressureSamples, 'valve_1', dict(step=[0.001] * 3, pressure=[1.0, 2.0, 3.0])),
    (FluidPressure, 'valve_1', dict(fluid_pressure=401325.0, variance=0.0)),
    (ValveCommand, '', dict(voltage=4.5, sample_period=0.001)),
    (LoadCommand, '', dict(mode=2, channel=1, setpoint=100.0)),
    (DriveLaw, '', dict(mode=1, setpoint=0.02, belt_stiffness=1e5, parameters=[1.0, 2.0],
                        state=[0.5], hold_contraction=[0.01, 0.02])),
    (TorqueServoState, '', dict(controller='pid', angle=0.1, torque_setpoint=1.5,
                                force_measured=[10.0, 20.0], status='')),
    (PoseWithCovarianceStamped, 'map', {}),       # nested default built by its constructor
    (Imu, 'imu', dict(linear_acceleration_covariance=[0.5] * 9)),      # fixed arrays
    (TorqueServoState, 's', dict(controller='dynamic_inverse_pid', angle=-0.2,
                                 force_setpoint=[100.0, 50.0], force_measured=[99.0, 51.0],
                                 contraction=[0.01, 0.02], u_feedforward=[1.0, 2.0],
                                 u_pid=[0.1, -0.1], voltage=[1.1, 1.9], status='x')),
]


def _reference(cls: type, frame: str, fields: dict[str, Any]) -> Any:
    msg = cls(**fields)
    msg.header.stamp = time_of(T_NS)
    msg.header.frame_id = frame
    return msg


@pytest.mark.parametrize(('cls', 'frame', 'fields'), CASES,
                         ids=[f'{c.__name__}{i}' for i, (c, _, _) in enumerate(CASES)])
def test_stamped_equals_the_constructor(cls: type, frame: str, fields: dict[str, Any]) -> None:
    ref = _reference(cls, frame, fields)
    msg = stamped(cls, T_NS, frame, **fields)
    assert type(msg) is cls
    assert msg == ref
    # rclpy leaves padding bytes as its buffer held them: compare what a reader gets back
    assert deserialize_message(serialize_message(msg), cls) == ref
    enc = encoder(cls)
    if enc is not None:
        assert enc(msg) == enc(ref)
    for name in cls.get_fields_and_field_types():              # same value types too
        assert type(getattr(msg, name)) is type(getattr(ref, name)), name


def test_fixed_arrays_are_fresh_numpy_arrays_of_the_field_type() -> None:
    assert _builder(Imu) is not None and _builder(TorqueServoState) is not None
    a, b = stamped(TorqueServoState, T_NS), stamped(TorqueServoState, T_NS, voltage=[1.0, 2.0])
    assert a.voltage.dtype == TorqueServoState().voltage.dtype and a.voltage.tolist() == [0, 0]
    a.voltage[0] = 5.0
    assert stamped(TorqueServoState, T_NS).voltage.tolist() == [0.0, 0.0]
    assert b.voltage.tolist() == [1.0, 2.0]


def test_unknown_field_is_an_error() -> None:
    with pytest.raises(TypeError, match='forse'):
        stamped(MuscleState, T_NS, forse=1.0)


def test_defaults_are_fresh_objects() -> None:
    a, b = stamped(JointState, T_NS), stamped(JointState, T_NS)
    a.position.append(1.0)
    assert list(b.position) == []


@pytest.mark.parametrize('t_ns', [0, 1, 999_999_999, 1_000_000_000, T_NS, 2**31 * 10**9 - 1])
def test_stamp_of_msg_reads_slots_as_the_properties_give(t_ns: int) -> None:
    """``stamp_of_msg`` and ``clock_ns`` read rosidl's slots directly: the same stamp as
    through the properties, for stamped messages built either way, a Clock and an object
    without slots."""
    from types import SimpleNamespace

    from rosgraph_msgs.msg import Clock

    from pam_bench.runtime.messages import clock_ns, stamp_of_msg
    built = stamped(FluidPressure, t_ns, 'valve_1', fluid_pressure=1.0)
    made = FluidPressure()
    made.header.stamp = time_of(t_ns)
    plain = SimpleNamespace(header=SimpleNamespace(stamp=SimpleNamespace(
        sec=t_ns // 10**9, nanosec=t_ns % 10**9)))
    for msg in (built, made, Clock(clock=time_of(t_ns)), plain):
        assert stamp_of_msg(msg) == t_ns
    assert clock_ns(Clock(clock=time_of(t_ns))) == t_ns
    assert clock_ns(SimpleNamespace(clock=plain.header.stamp)) == t_ns


@pytest.mark.parametrize('names, positions, want', [
    (['pulley'], [0.5], 0.5), (['motor', 'pulley'], [9.0, 0.25], 0.25), ([], [0.75], 0.75),
    ([], [], None), (['motor'], [0.1], None), (['pulley'], [], None),
    (['a', 'pulley'], [1.0], None), ([], [1.0, 2.0], None)])
def test_a_joint_is_read_by_name(names: list, positions: list, want: float | None) -> None:
    import math

    from sensor_msgs.msg import JointState

    from pam_bench.runtime.stamped import joint_position
    got = joint_position(JointState(name=names, position=positions), 'pulley')
    assert (math.isnan(got) if want is None else got == want)
