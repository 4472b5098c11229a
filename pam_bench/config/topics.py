"""The topic contract: every topic's name and type in one table (README, "Topics").

Nodes create their publishers and subscriptions from these names (relative names, so a node
started in a namespace keeps its devices together), the recorder records them, the extraction
reads them back from bags (absolute names). Types are 'package/msg/Type' strings: this module
needs no ROS install. ``N`` is the muscle channel, 1 or 2.
"""

from __future__ import annotations

import dataclasses

__all__ = ['Topic', 'TOPICS', 'valve_command', 'valve_pressure', 'valve_samples',
           'muscle_state', 'muscle_samples', 'load_cell_force', 'ENCODER', 'LOAD_COMMAND',
           'LOAD_STATE', 'MOTOR_JOINT', 'PULLEY_JOINT', 'PULLEY_STATE', 'PULLEY_LAW', 'POINT',
           'RECORD', 'STATUS', 'RUN', 'PAUSE', 'RESUME', 'SERVO_SETPOINT', 'SERVO_STATE',
           'SERVO_RESET', 'DIAGNOSTICS',
           'CLOCK', 'ACK', 'EVENT_TOPICS', 'STEP_TOPICS', 'step_topics',
           'absolute', 'in_namespace', 'same_topic']


def valve_command(ch: int) -> str:
    """ValveCommand to valve N (control voltage, V)."""
    return f'valve_{ch}/command'


def valve_pressure(ch: int) -> str:
    """FluidPressure of valve N's output (absolute Pa)."""
    return f'valve_{ch}/pressure'


def valve_samples(ch: int) -> str:
    """PressureSamples of valve N at every sub-step (simulation only)."""
    return f'sim/valve_{ch}/samples'


def muscle_state(ch: int) -> str:
    """MuscleState of muscle N: ground truth (simulation only)."""
    return f'sim/muscle_{ch}/state'


def muscle_samples(ch: int) -> str:
    """MuscleSamples of muscle N at every sub-step (simulation only)."""
    return f'sim/muscle_{ch}/samples'


def load_cell_force(ch: int) -> str:
    """WrenchStamped of load cell N (``force.x``, N)."""
    return f'load_cell_{ch}/force'


ENCODER = 'encoder/joint_state'
LOAD_COMMAND = 'loading_servo/command'
LOAD_STATE = 'loading_servo/state'
MOTOR_JOINT = 'motor'
PULLEY_JOINT = 'pulley'
"""The joint of ``loading_servo/state`` (the motor side: angle rad, rate rad/s, torque N m)."""
PULLEY_STATE = 'sim/pulley/state'
PULLEY_LAW = 'sim/pulley/law'
POINT = 'protocol/point'
RECORD = 'protocol/step_response'
STATUS = 'protocol/status'
RUN = 'protocol/run'
PAUSE = 'protocol/pause'
RESUME = 'protocol/resume'
SERVO_SETPOINT = 'torque_servo/setpoint'
SERVO_STATE = 'torque_servo/state'
SERVO_RESET = 'torque_servo/reset'
DIAGNOSTICS = 'diagnostics'
"""REP-107's /diagnostics in the root namespace; relative, so that two benches in one domain
under two namespaces keep theirs apart (remap ``diagnostics:=/diagnostics`` to merge them)."""
CLOCK = '/clock'
ACK = '/sim/ack'


@dataclasses.dataclass(frozen=True)
class Topic:
    """One topic of the contract: absolute name, type, publishers (scene node names)."""

    name: str
    msgtype: str
    sources: tuple[str, ...]

    @property
    def spec(self) -> str:
        """``name:type``, the recorder's parameter format."""
        return f'{self.name}:{self.msgtype}'


def absolute(name: str) -> str:
    """The absolute name of a contract topic (nodes run in the root namespace)."""
    return name if name.startswith('/') else f'/{name}'


def in_namespace(name: str, namespace: str) -> str:
    """The topic ``name`` (absolute, as the contract and a recorder's settings give it) of a
    bench whose nodes run in ``namespace`` ('' or '/': the root): ``/load_cell_1/force`` in
    ``/bench_a`` is ``/bench_a/load_cell_1/force``. The clock stays global."""
    name = absolute(name)
    ns = namespace.rstrip('/')
    return name if not ns or name == CLOCK else f'{ns}{name}'


def same_topic(bag_topic: str, name: str) -> bool:
    """Whether a bag's topic is the contract topic ``name`` recorded in some namespace (a
    bag holds one bench's topics: ``pam-bench run --namespace``)."""
    name = absolute(name)
    return bag_topic == name or bag_topic.endswith(name)


_PB = 'pam_bench_interfaces/msg/'
# every topic published at every exchange step, with the nodes that can publish it (the
# recorder records them all, the sub-step ``samples`` topics only when the scene asks:
# ``record_samples``; sim/pulley/law, the drive's law for the next exchange, is left out)
TOPICS: tuple[Topic, ...] = (
    *(t for ch in (1, 2) for t in (
        Topic(absolute(valve_command(ch)), _PB + 'ValveCommand',
              ('sequencer', 'torque_servo') if ch == 1 else ('torque_servo',)),
        Topic(absolute(valve_pressure(ch)), 'sensor_msgs/msg/FluidPressure', (f'valve_{ch}',)),
        Topic(absolute(valve_samples(ch)), _PB + 'PressureSamples', (f'valve_{ch}',)),
        Topic(absolute(muscle_state(ch)), _PB + 'MuscleState', (f'muscle_{ch}',)),
        Topic(absolute(muscle_samples(ch)), _PB + 'MuscleSamples', (f'muscle_{ch}',)),
        Topic(absolute(load_cell_force(ch)), 'geometry_msgs/msg/WrenchStamped',
              (f'load_cell_{ch}',)))),
    Topic(absolute(ENCODER), 'sensor_msgs/msg/JointState', ('encoder',)),
    Topic(absolute(LOAD_COMMAND), _PB + 'LoadCommand', ('sequencer',)),
    Topic(absolute(LOAD_STATE), 'sensor_msgs/msg/JointState', ('loading_servo',)),
    Topic(absolute(PULLEY_STATE), 'sensor_msgs/msg/JointState', ('loading_servo',)),
    Topic(absolute(SERVO_STATE), _PB + 'TorqueServoState', ('torque_servo',)),
    Topic(CLOCK, 'rosgraph_msgs/msg/Clock', ('sim_clock',)),
)

EVENT_TOPICS = [
    f'{absolute(POINT)}:{_PB}CharacteristicPoint',
    f'{absolute(RECORD)}:{_PB}StepResponseRecord',
    f'{absolute(STATUS)}:{_PB}ProtocolStatus',
    f'{absolute(DIAGNOSTICS)}:diagnostic_msgs/msg/DiagnosticArray',
]


def step_topics(nodes: list[str], samples: bool = False) -> list[str]:
    """The step topics (``name:type``) some node of a scene publishes (the recorder waits for
    each); a command topic (``/DEVICE/command``) only when the scene has that device; the
    sub-step ``samples`` topics only with ``samples``."""
    have = {*nodes, 'sim_clock'}

    def present(t: Topic) -> bool:
        device_ok = not t.name.endswith('/command') or t.name.split('/')[1] in have
        return bool(set(t.sources) & have) and device_ok

    return [t.spec for t in TOPICS if present(t)
            and (samples or not t.name.endswith('/samples'))]


# the single-muscle characterisation bench
STEP_TOPICS = step_topics(['valve_1', 'muscle_1', 'load_cell_1', 'encoder', 'loading_servo',
                           'sequencer', 'recorder'])
