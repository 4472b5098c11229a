"""Scenes: which nodes a run brings up, their parameters, the exchange step and the protocol.

A scene file (config/scenes/NAME.yaml) holds ``description``, ``exchange_step_s`` (the
longest exchange step: the devices ask for shorter ones where they need them), ``protocol``,
``nodes`` (names from ``NODE_TYPES``), optional ``duration_s``, optional ``sub_step_s`` (the
sub-step of the valve's pressure samples, which the muscle and the drive are solved on inside
every exchange; 5 ms by default), optional ``record_samples`` (record those sub-step samples,
``sim/valve_N/samples`` and ``sim/muscle_N/samples``, too; false by default: they are most of
a bag), optional ``faults`` (injected faults, wall clock only: ``sim.faults``), optional
``parameters`` (per node, merged over
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

from pam_bench.config.paths import config_dir, scenes_dir
from pam_bench.config.protocols import protocol_config
from pam_bench.config.topics import EVENT_TOPICS, step_topics
from pam_bench.config.yaml_io import ConfigError, read_yaml
from pam_bench.control.torque_servo import TorqueServoParams
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.errors import ParameterError
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.params import check_known, from_mapping, hint, nearest
from pam_bench.models.sensors import EncoderParams, LoadCellParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveParams
from pam_bench.sim.faults import Fault, parse_faults

__all__ = ['NodeType', 'NODE_TYPES', 'Scene', 'load_scene', 'scene_names', 'SCENE_KEYS',
           'apply_overlay']


@dataclasses.dataclass(frozen=True)
class NodeType:
    """Where a node's class lives and what it contributes to the lock-step."""

    module: str
    cls: str
    lockstep: bool = True
    models: tuple[tuple[str, type], ...] = ()     # (parameter prefix, parameter dataclass)


_VALVE = (('valve', ValveParams),)
_MUSCLE = (('muscle', MuscleParams), ('straight_fibre', StraightFibreParams))
_CELL = (('load_cell', LoadCellParams),)
NODE_TYPES = {
    'valve_1': NodeType('pam_bench.nodes.valve_sim', 'ValveSim', models=_VALVE),
    'muscle_1': NodeType('pam_bench.nodes.muscle_sim', 'MuscleSim', models=_MUSCLE),
    'load_cell_1': NodeType('pam_bench.nodes.load_cell_sim', 'LoadCellSim', models=_CELL),
    'encoder': NodeType('pam_bench.nodes.encoder_sim', 'EncoderSim',
                        models=(('encoder', EncoderParams),)),
    'loading_servo': NodeType('pam_bench.nodes.loading_servo_sim', 'LoadingServoSim',
                              models=(('servo', LoadingServoParams),)),
    'valve_2': NodeType('pam_bench.nodes.valve_sim', 'ValveSim', models=_VALVE),
    'muscle_2': NodeType('pam_bench.nodes.muscle_sim', 'MuscleSim', models=_MUSCLE),
    'load_cell_2': NodeType('pam_bench.nodes.load_cell_sim', 'LoadCellSim', models=_CELL),
    'sequencer': NodeType('pam_bench.nodes.sequencer', 'SequencerNode'),
    'torque_servo': NodeType('pam_bench.nodes.torque_servo', 'TorqueServoNode',
                             models=(('servo', TorqueServoParams),)),
    'recorder': NodeType('pam_bench.nodes.recorder', 'Recorder'),
    'sim_clock': NodeType('pam_bench.nodes.sim_clock', 'SimClock', lockstep=False),
}

def scene_names() -> list[str]:
    """Names of the scenes in config/scenes/."""
    return sorted(p.stem for p in scenes_dir().glob('*.yaml'))


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
    sub_step_s: float = SUB_STEP_S
    record_samples: bool = False
    source: str = ''             # the scene file's text (a bag keeps it: ``--replay``)
    faults: list[Fault] = dataclasses.field(default_factory=list)   # wall clock only

    def node_parameters(self, out_dir: str, seed: int, realtime: bool) -> dict[str, Any]:
        """Parameters of every node: config/bench.yaml, then the scene, then this run."""
        base = read_yaml(config_dir() / 'bench.yaml')
        common = dict(base.get('/**', {}).get('ros__parameters', {}))
        out: dict[str, Any] = {}
        for name in self.nodes + ['sim_clock']:
            params = dict(common) if name != 'sim_clock' else {}
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


SCENE_KEYS: dict[str, tuple[type | tuple[type, ...], str]] = {
    'description': (str, 'a string'),
    'exchange_step_s': ((int, float), 'a number of seconds'),
    'protocol': (str, 'a protocol name'),
    'nodes': (list, 'a list of node names'),
    'duration_s': ((int, float), 'a number of seconds'),
    'sub_step_s': ((int, float), 'a number of seconds'),
    'record_samples': (bool, 'true or false'),
    'parameters': (dict, 'a mapping node -> parameters'),
    'protocol_overrides': (dict, 'a mapping of protocol keys'),
    'faults': (list, 'a list of faults (sim.faults)'),
}
"""Every key a scene file may hold: its type and how the error message names that type."""
REQUIRED = ('nodes', 'exchange_step_s')
GONE = {'coupling': 'every exchange is now solved on sub-steps: see sub_step_s',
        'record_exchange_s': 'every exchange is now solved on sub-steps: see sub_step_s'}


def _typed(where: str, data: dict[str, Any], key: str, default: Any = None) -> Any:
    kind, text = SCENE_KEYS[key]
    if key not in data:
        if key in REQUIRED:
            raise ConfigError(f'{where}: missing key {key!r}')
        return default
    value = data[key]
    if value is None and key in ('parameters', 'protocol_overrides'):
        return default
    if (isinstance(value, bool) and kind is not bool) or not isinstance(value, kind):
        raise ConfigError(f'{where}: key {key!r} must be {text}, got {value!r}')
    return value


def _check_parameters(where: str, nodes: list[str], parameters: dict[str, Any]) -> None:
    """Node names and model sections of a scene's ``parameters`` (plain node parameters are
    checked by the node itself at start-up: ``nodes.process.reject_undeclared``)."""
    check_known(parameters, [*nodes, 'sim_clock'], f'{where}, parameters')
    for node, values in parameters.items():
        if not isinstance(values, dict):
            raise ConfigError(f'{where}: parameters.{node} must be a mapping, got {values!r}')
        for prefix, cls in NODE_TYPES[node].models:
            section = values.get(prefix)
            if section is None:
                continue
            if not isinstance(section, dict):
                raise ConfigError(f'{where}: parameters.{node}.{prefix} must be a mapping')
            try:
                from_mapping(cls, section, f'{node}.{prefix}.')
            except ParameterError as exc:
                raise ConfigError(f'{where}: {exc}') from None


def load_scene(name: str) -> Scene:
    """Load config/scenes/NAME.yaml (or a path to a scene file), strictly.

    Raises:
        ConfigError: an unknown scene, node or key (named, with the nearest known one), a
            value of the wrong type or out of range (named).
    """
    path = pathlib.Path(name)
    if not path.suffix:
        path = scenes_dir() / f'{name}.yaml'
    if not path.exists():
        raise ConfigError(f'no scene {name!r} ({hint(name, scene_names())})')
    try:
        return _parse_scene(path, read_yaml(path))
    except ConfigError:
        raise
    except ParameterError as exc:
        raise ConfigError(str(exc)) from None


def _parse_scene(path: pathlib.Path, data: dict[str, Any]) -> Scene:
    where = f'scene {path.name}'
    for old, why in GONE.items():
        if old in data:
            raise ConfigError(f'{where}: key {old!r} is gone ({why})')
    check_known(data, SCENE_KEYS, where)
    nodes = _typed(where, data, 'nodes')
    for n in nodes:
        if n not in NODE_TYPES or n == 'sim_clock':
            near = nearest(str(n), NODE_TYPES)
            raise ConfigError(f'{where}: unknown node {n!r}'
                              + (f' (did you mean {near!r}?)' if near else ''))
    step = _typed(where, data, 'exchange_step_s')
    if not 0 < step <= 10:
        raise ConfigError(f'{where}: exchange_step_s {step} out of (0, 10] s')
    sub = _typed(where, data, 'sub_step_s', SUB_STEP_S)
    if not 1e-5 <= sub <= 1.0:
        raise ConfigError(f'{where}: sub_step_s {sub} out of [1e-5, 1] s')
    duration = _typed(where, data, 'duration_s', 0.0)
    if duration < 0:
        raise ConfigError(f'{where}: duration_s {duration} is negative')
    parameters = dict(_typed(where, data, 'parameters', {}))
    _check_parameters(where, nodes, parameters)
    protocol = _typed(where, data, 'protocol', '')
    overrides = dict(_typed(where, data, 'protocol_overrides', {}))
    if 'sequencer' in nodes:
        try:
            protocol_config(protocol, overrides)
        except ParameterError as exc:
            raise ConfigError(f'{where}: {exc}') from None
    try:
        faults = parse_faults(_typed(where, data, 'faults', []), list(nodes))
    except ParameterError as exc:
        raise ConfigError(f'{where}: {exc}') from None
    return Scene(path.stem, _typed(where, data, 'description', ''), float(step), protocol,
                 list(nodes), float(duration), parameters, overrides, float(sub),
                 _typed(where, data, 'record_samples', False), path.read_text(encoding='utf-8'),
                 faults)


def apply_overlay(scene: Scene, path: str | pathlib.Path) -> None:
    """Merge a parameter overlay (``pam-bench calibrate --out``, ``run --params``) into a
    scene: the file holds one key, ``parameters`` (node -> parameters, as in a scene); its
    values go over config/bench.yaml and under the scene's own. Nodes the scene does not run
    are skipped (an overlay for two muscles fits a one-muscle scene).

    Raises:
        ConfigError: an unreadable file, an unknown key, node or parameter (named).
    """
    where = f'overlay {pathlib.Path(path).name}'
    data = read_yaml(pathlib.Path(path))
    params = data.get('parameters') or {}
    try:
        check_known(data, ['parameters'], where)
        if not isinstance(params, dict):
            raise ConfigError(f'{where}: parameters must be a mapping node -> parameters')
        check_known(params, [n for n in NODE_TYPES if n != 'sim_clock'], f'{where}, parameters')
    except ParameterError as exc:
        raise ConfigError(str(exc)) from None
    _check_parameters(where, list(params), params)
    for node in scene.nodes:
        if node in params:
            merged = copy.deepcopy(params[node])
            _merge(merged, scene.parameters.get(node, {}))
            scene.parameters[node] = merged
