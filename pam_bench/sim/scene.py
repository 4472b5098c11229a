"""Scenes: which nodes a run brings up, their parameters, the exchange step and the protocol.

A scene file (config/scenes/NAME.yaml) holds ``description``, ``exchange_step_s`` (the
longest exchange step: the devices ask for shorter ones where they need them), ``protocol``,
``nodes`` (names from ``NODE_TYPES``), optional ``duration_s``, optional ``sub_step_s`` (the
sub-step of the valve's pressure samples, which the muscle and the drive are solved on inside
every exchange; 5 ms by default), optional ``record_samples`` (record those sub-step samples,
``sim/valve_N/samples`` and ``sim/muscle_N/samples``, too; false by default: they are most of
a bag), optional ``parameters`` (per node, merged over
config/bench.yaml) and optional ``protocol_overrides`` (merged over the protocol's entry in
config/protocols.yaml). ``node_parameters`` returns the parameters of every node of the run in
the ROS 2 params-file layout.
"""

from __future__ import annotations

import copy
import dataclasses
import pathlib
from typing import Any

import yaml

from pam_bench.models.errors import ParameterError

__all__ = ['NodeType', 'NODE_TYPES', 'Scene', 'config_dir', 'load_scene', 'scene_names',
           'STEP_TOPICS', 'STEP_TOPIC_SOURCES', 'EVENT_TOPICS', 'step_topics']


@dataclasses.dataclass(frozen=True)
class NodeType:
    """Where a node's class lives and what it contributes to the lock-step."""

    module: str
    cls: str
    lockstep: bool = True


NODE_TYPES = {
    'valve_1': NodeType('pam_bench.nodes.valve_sim', 'ValveSim'),
    'muscle_1': NodeType('pam_bench.nodes.muscle_sim', 'MuscleSim'),
    'load_cell_1': NodeType('pam_bench.nodes.load_cell_sim', 'LoadCellSim'),
    'encoder': NodeType('pam_bench.nodes.encoder_sim', 'EncoderSim'),
    'loading_servo': NodeType('pam_bench.nodes.loading_servo_sim', 'LoadingServoSim'),
    'valve_2': NodeType('pam_bench.nodes.valve_sim', 'ValveSim'),
    'muscle_2': NodeType('pam_bench.nodes.muscle_sim', 'MuscleSim'),
    'load_cell_2': NodeType('pam_bench.nodes.load_cell_sim', 'LoadCellSim'),
    'sequencer': NodeType('pam_bench.nodes.sequencer', 'SequencerNode'),
    'torque_servo': NodeType('pam_bench.nodes.torque_servo', 'TorqueServoNode'),
    'recorder': NodeType('pam_bench.nodes.recorder', 'Recorder'),
    'sim_clock': NodeType('pam_bench.nodes.sim_clock', 'SimClock', lockstep=False),
}

# every topic published at every exchange step, with the nodes that can publish it (the
# recorder records them all, the sub-step ``samples`` topics only when the scene asks:
# ``record_samples``; sim/pulley/law, the drive's law for the next exchange, is left out)
STEP_TOPIC_SOURCES = {
    '/valve_1/command:pam_bench_interfaces/msg/ValveCommand': ('sequencer', 'torque_servo'),
    '/valve_1/pressure:sensor_msgs/msg/FluidPressure': ('valve_1',),
    '/sim/valve_1/samples:pam_bench_interfaces/msg/PressureSamples': ('valve_1',),
    '/sim/muscle_1/state:pam_bench_interfaces/msg/MuscleState': ('muscle_1',),
    '/sim/muscle_1/samples:pam_bench_interfaces/msg/MuscleSamples': ('muscle_1',),
    '/load_cell_1/force:geometry_msgs/msg/WrenchStamped': ('load_cell_1',),
    '/valve_2/command:pam_bench_interfaces/msg/ValveCommand': ('torque_servo',),
    '/valve_2/pressure:sensor_msgs/msg/FluidPressure': ('valve_2',),
    '/sim/valve_2/samples:pam_bench_interfaces/msg/PressureSamples': ('valve_2',),
    '/sim/muscle_2/state:pam_bench_interfaces/msg/MuscleState': ('muscle_2',),
    '/sim/muscle_2/samples:pam_bench_interfaces/msg/MuscleSamples': ('muscle_2',),
    '/load_cell_2/force:geometry_msgs/msg/WrenchStamped': ('load_cell_2',),
    '/encoder/joint_state:sensor_msgs/msg/JointState': ('encoder',),
    '/loading_servo/command:pam_bench_interfaces/msg/LoadCommand': ('sequencer',),
    '/loading_servo/state:sensor_msgs/msg/JointState': ('loading_servo',),
    '/sim/pulley/state:sensor_msgs/msg/JointState': ('loading_servo',),
    '/torque_servo/state:pam_bench_interfaces/msg/TorqueServoState': ('torque_servo',),
    '/clock:rosgraph_msgs/msg/Clock': ('sim_clock',),
}


def step_topics(nodes: list[str], samples: bool = False) -> list[str]:
    """The step topics some node of a scene publishes (the recorder waits for each); a
    command topic (``/DEVICE/command``) is published only to a device the scene has; the
    sub-step ``samples`` topics only with ``samples``."""
    have = {*nodes, 'sim_clock'}

    def present(topic: str, sources: tuple[str, ...]) -> bool:
        name = topic.split(':')[0]
        device_ok = not name.endswith('/command') or name.split('/')[1] in have
        return bool(set(sources) & have) and device_ok

    return [t for t, src in STEP_TOPIC_SOURCES.items() if present(t, src)
            and (samples or not t.split(':')[0].endswith('/samples'))]


# the single-muscle characterisation bench
STEP_TOPICS = step_topics(['valve_1', 'muscle_1', 'load_cell_1', 'encoder', 'loading_servo',
                           'sequencer', 'recorder'])
EVENT_TOPICS = [
    '/protocol/point:pam_bench_interfaces/msg/CharacteristicPoint',
    '/protocol/step_response:pam_bench_interfaces/msg/StepResponseRecord',
    '/protocol/status:pam_bench_interfaces/msg/ProtocolStatus',
    '/diagnostics:diagnostic_msgs/msg/DiagnosticArray',
]


def config_dir() -> pathlib.Path:
    """The config/ folder of the source tree, else of the installed package."""
    src = pathlib.Path(__file__).resolve().parents[2] / 'config'
    if src.is_dir():
        return src
    from ament_index_python.packages import get_package_share_directory
    return pathlib.Path(get_package_share_directory('pam_bench')) / 'config'


def scene_names() -> list[str]:
    """Names of the scenes in config/scenes/."""
    return sorted(p.stem for p in (config_dir() / 'scenes').glob('*.yaml'))


@dataclasses.dataclass
class Scene:
    """A loaded scene."""

    name: str
    description: str
    exchange_step_s: float
    protocol: str
    nodes: list[str]
    duration_s: float
    parameters: dict[str, dict[str, Any]]
    protocol_overrides: dict[str, Any] = dataclasses.field(default_factory=dict)
    sub_step_s: float = 0.005
    record_samples: bool = False

    def node_parameters(self, out_dir: str, seed: int, realtime: bool) -> dict[str, Any]:
        """Parameters of every node: config/bench.yaml, then the scene, then this run."""
        base = _read_yaml(config_dir() / 'bench.yaml')
        common = dict(base.get('/**', {}).get('ros__parameters', {}))
        out: dict[str, Any] = {}
        for name in self.nodes + ['sim_clock']:
            params = dict(common)
            # deep copies: bench.yaml shares one mapping between the channels (YAML anchors)
            params.update(copy.deepcopy(base.get(name, {}).get('ros__parameters', {})))
            _merge(params, copy.deepcopy(self.parameters.get(name, {})))
            model = params.get('inverse_model_file')
            if model and not pathlib.Path(model).is_absolute():
                params['inverse_model_file'] = str(config_dir().parent / model)
            out[name] = {'ros__parameters': params}
        participants = [f'/{n}' for n in self.nodes if NODE_TYPES[n].lockstep]
        out['sim_clock']['ros__parameters'].update(
            exchange_step_s=self.exchange_step_s, participants=participants,
            duration_s=self.duration_s, realtime=realtime, use_sim_time=False)
        for name in self.nodes:
            if name.startswith('valve_'):
                out[name]['ros__parameters']['sub_step_s'] = self.sub_step_s
        if 'sequencer' in out:
            out['sequencer']['ros__parameters']['protocol'] = self.protocol
            if self.protocol_overrides:
                out['sequencer']['ros__parameters']['protocol_overrides_yaml'] = yaml.safe_dump(
                    self.protocol_overrides)
        if 'recorder' in out:
            out['recorder']['ros__parameters'].update(out_dir=out_dir,
                                                      step_topics=step_topics(
                                                          self.nodes, self.record_samples),
                                                      event_topics=EVENT_TOPICS)
        for i in (1, 2):
            if f'load_cell_{i}' in out:
                out[f'load_cell_{i}']['ros__parameters']['seed'] = seed + i - 1
        return out


def _merge(dst: dict[str, Any], src: dict[str, Any]) -> None:
    for k, v in src.items():
        if isinstance(v, dict) and isinstance(dst.get(k), dict):
            _merge(dst[k], v)
        else:
            dst[k] = v


def _read_yaml(path: pathlib.Path) -> dict[str, Any]:
    try:
        with open(path, encoding='utf-8') as fh:
            data = yaml.safe_load(fh) or {}
    except yaml.YAMLError as exc:
        raise ParameterError(f'{path}: not valid YAML: {exc}') from None
    if not isinstance(data, dict):
        raise ParameterError(f'{path}: expected a mapping at the top level')
    return data


def load_scene(name: str) -> Scene:
    """Load config/scenes/NAME.yaml (or a path to a scene file).

    Raises:
        ParameterError: unknown scene, or a missing or malformed key (named).
    """
    path = pathlib.Path(name)
    if not path.suffix:
        path = config_dir() / 'scenes' / f'{name}.yaml'
    if not path.exists():
        raise ParameterError(f'no scene {name!r}; known: {", ".join(scene_names())}')
    data = _read_yaml(path)

    def need(key: str, kind: type) -> Any:
        if key not in data:
            raise ParameterError(f'scene {path.name}: missing key {key!r}')
        if not isinstance(data[key], kind):
            raise ParameterError(f'scene {path.name}: key {key!r} must be {kind.__name__}')
        return data[key]

    nodes = need('nodes', list)
    unknown = [n for n in nodes if n not in NODE_TYPES]
    if unknown:
        raise ParameterError(f'scene {path.name}: unknown node {unknown[0]!r}; known: '
                             f'{", ".join(NODE_TYPES)}')
    step = need('exchange_step_s', (int, float))
    if not 0 < step <= 10:
        raise ParameterError(f'scene {path.name}: exchange_step_s {step} out of (0, 10] s')
    sub = data.get('sub_step_s', 0.005)
    if isinstance(sub, bool) or not isinstance(sub, (int, float)) or not 1e-5 <= sub <= 1.0:
        raise ParameterError(f'scene {path.name}: sub_step_s must be a number in [1e-5, 1] s')
    for old in ('coupling', 'record_exchange_s'):
        if old in data:
            raise ParameterError(f'scene {path.name}: key {old!r} is gone (every exchange is '
                                 'now solved on sub-steps: see sub_step_s)')
    samples = data.get('record_samples', False)
    if not isinstance(samples, bool):
        raise ParameterError(f'scene {path.name}: record_samples must be true or false')
    return Scene(path.stem, str(data.get('description', '')), float(step),
                 str(data.get('protocol', '')), list(nodes), float(data.get('duration_s', 0.0)),
                 dict(data.get('parameters', {}) or {}),
                 dict(data.get('protocol_overrides', {}) or {}), float(sub), samples)
