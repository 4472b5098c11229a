"""Scenes: which nodes a run brings up, their settings, the exchange step and the protocol.

A scene file (config/scenes/NAME.yaml) holds ``description``, ``exchange_step_s`` (the
longest exchange step: the devices ask for shorter ones where they need them), ``protocol``,
``nodes`` (names from ``config.nodes.NODES``), optional ``duration_s``, optional ``sub_step_s``
(the sub-step of the valve's pressure samples, which the muscle and the drive are solved on
inside every exchange; 5 ms by default), optional ``record_samples`` (record those sub-step
samples, ``sim/valve_N/samples`` and ``sim/muscle_N/samples``, too; false by default: they are
most of a bag), optional ``faults`` (injected faults, wall clock only: ``sim.faults``), optional
``parameters`` (per node, over config/bench.yaml) and optional ``protocol_overrides`` (merged
over the protocol's entry in config/protocols.yaml).

``Scene.settings`` returns every node's typed settings (``config.settings``): the dataclass
defaults, then config/bench.yaml, then the scene's ``parameters`` (with any overlay under them),
then what the scene and the run fix (sub-step, protocol, seed, bag folder, clock). Every value
is checked when the scene loads, so a misspelt key anywhere is one line naming it and the
nearest known one. ``Scene.set`` changes one setting by path (``muscle_1.muscle.gain_exponent``:
sweeps, ``--set``).
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import pathlib
from typing import Any

import yaml

from pam_bench.config.errors import ConfigError
from pam_bench.config.nodes import NODES, SCENE_NODES, Role, node
from pam_bench.config.paths import config_dir, scenes_dir
from pam_bench.config.protocols import protocol_schedule
from pam_bench.config.settings import LawSettings
from pam_bench.config.topics import EVENT_TOPICS, step_topics
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.sim.faults import Fault, parse_faults
from pam_bench.vocabulary.errors import ParameterError, shorten
from pam_bench.vocabulary.params import (
    check_known,
    deep_merge,
    from_mapping,
    hint,
    nearest,
    to_mapping,
    with_path,
)
from pam_bench.vocabulary.yaml_io import parse_yaml, read_text, read_yaml

__all__ = ['Scene', 'load_scene', 'scene_names', 'SCENE_KEYS', 'apply_overlay', 'bench_overlay',
           'params_file', 'settings_of_params_file', 'law_notes', 'DEFAULT_LAW']


def scene_names() -> list[str]:
    """Names of the scenes in config/scenes/."""
    return sorted(p.stem for p in scenes_dir().glob('*.yaml'))


@functools.lru_cache(maxsize=4)
def _bench_yaml(path: pathlib.Path) -> dict[str, dict[str, Any]]:
    data = read_yaml(path)
    where = f'{path.name}'
    try:
        check_known(data, NODES, where)
    except ParameterError as exc:
        raise ConfigError(str(exc)) from None
    out = {}
    for name, entry in data.items():
        if not isinstance(entry, dict) or set(entry) != {'ros__parameters'}:
            raise ConfigError(f'{where}: {name} must hold one key, ros__parameters (the ROS 2 '
                              'params-file layout)')
        out[name] = dict(entry['ros__parameters'] or {})
    return out


def bench_overlay() -> dict[str, dict[str, Any]]:
    """config/bench.yaml: node -> the values the simulated bench sets over the defaults.

    Raises:
        ConfigError: an unreadable file, an unknown node or a malformed entry.
    """
    return copy.deepcopy(_bench_yaml(config_dir() / 'bench.yaml'))


def params_file(settings: dict[str, Any]) -> dict[str, Any]:
    """Settings of a run in the ROS 2 params-file layout (node -> ros__parameters)."""
    return {name: {'ros__parameters': to_mapping(s)} for name, s in settings.items()}


def node_of_key(key: str) -> str:
    """The node a params-file key names: ``sequencer``, ``/sequencer`` and
    ``/**/sequencer`` (any namespace, what ``pam-bench params --ros-yaml`` writes) all name
    ``sequencer``."""
    return str(key).rstrip('/').rsplit('/', 1)[-1]


def settings_of_params_file(params: dict[str, Any], where: str = 'parameters'
                            ) -> dict[str, Any]:
    """The settings a params-file mapping holds (a bag's recorded parameters: ``--replay``).

    Raises:
        ConfigError: an unknown node or setting, a bad value (named).
    """
    out: dict[str, Any] = {}
    try:
        for key, entry in params.items():
            name = node_of_key(key)
            values = _installed_laws_only((entry or {}).get('ros__parameters', {}), name)
            out[name] = from_mapping(node(name).settings, values, f'{name}.')
    except ParameterError as exc:
        raise ConfigError(f'{where}: {exc}') from None
    return out


def _installed_laws_only(values: dict[str, Any], name: str) -> dict[str, Any]:
    """``values`` without the parameter sections of force laws not installed here: a bag
    recorded where a plug-in law was installed carries its section (every law's parameters are
    settings) even when its muscle held another law. A muscle that held such a law cannot be
    rebuilt: one line says which plug-in to install.

    Raises:
        ConfigError: the muscle's own law is a plug-in not installed here.
    """
    laws = values.get('laws')
    if not isinstance(laws, dict):
        return values
    known = {f.name for f in dataclasses.fields(LawSettings)}
    missing = sorted(set(laws) - known, key=str)
    if not missing:
        return values
    muscle = values.get('muscle')
    held = muscle.get('law') if isinstance(muscle, dict) and muscle.get('kind') == 'law' else None
    if held in missing:
        raise ConfigError(f"{name}'s muscle holds the force law {held!r}, a plug-in not "
                          'installed here: install its package (pam-bench plugins lists the '
                          'laws there are)')
    return {**values, 'laws': {k: v for k, v in laws.items() if k in known}}


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

    def settings(self, out_dir: str = '', seed: int = 0, realtime: bool = False
                 ) -> dict[str, Any]:
        """Every node's settings (the sim clock's last): the defaults, config/bench.yaml, the
        scene's parameters, then what the scene and this run fix.

        Raises:
            ConfigError: an unknown setting or a bad value, named by its path.
        """
        base = bench_overlay()
        out: dict[str, Any] = {}
        participants = [f'/{n}' for n in self.nodes if NODES[n].lockstep]
        for name in [*self.nodes, 'sim_clock']:
            t = NODES[name]
            values: dict[str, Any] = {'channel': t.channel} if t.channel else {}
            deep_merge(values, base.get(name, {}))
            deep_merge(values, self.parameters.get(name, {}))
            if t.executable == 'valve_sim':
                values['sub_step_s'] = self.sub_step_s
            if name == 'sequencer':
                values['protocol'] = self.protocol
                if self.protocol_overrides:
                    values['protocol_overrides_yaml'] = yaml.safe_dump(self.protocol_overrides)
            if name == 'recorder':
                values.update(out_dir=out_dir, event_topics=list(EVENT_TOPICS),
                              step_topics=step_topics(self.nodes, self.record_samples))
            if name.startswith('load_cell_'):
                values['seed'] = seed + t.channel - 1
            if name == 'torque_servo' and values.get('inverse_model_file'):
                model = pathlib.Path(values['inverse_model_file'])
                if not model.is_absolute():
                    values['inverse_model_file'] = str(config_dir().parent / model)
            if t.role == Role.CLOCK:
                values.update(exchange_step_s=self.exchange_step_s, participants=participants,
                              duration_s=self.duration_s, realtime=realtime)
            try:
                out[name] = from_mapping(t.settings, values, f'{name}.')
            except ParameterError as exc:
                raise ConfigError(f'scene {self.name}: {exc}') from None
            muscle = getattr(out[name], 'muscle', None)
            if muscle is not None:         # a law left to auto: decided for this scene's steps
                from pam_bench.models.law_muscle import with_law_core
                out[name] = dataclasses.replace(out[name], muscle=with_law_core(
                    muscle, self.exchange_step_s, self.sub_step_s))
        _check_inputs(self.name, out)
        return out

    def set(self, path: str, value: Any) -> None:
        """Set one node setting by its path (``muscle_1.muscle.gain_exponent``), over the
        scene's own value.

        Raises:
            ConfigError: an unknown node or setting (the nearest named) or a bad value.
        """
        name, _, rest = path.partition('.')
        if rest.endswith('_yaml') and not isinstance(value, str):   # YAML text, given parsed
            value = yaml.safe_dump(value, default_flow_style=True, width=10**6).strip()
        if name not in self.nodes and name != 'sim_clock':        # the clock is in every run
            known = [*self.nodes, 'sim_clock']
            raise ConfigError(f"scene {self.name}: unknown setting '{path}' (node {name!r} is "
                              f'not in this scene; {hint(name, known)})')
        try:
            cls = NODES[name].settings
            with_path(cls(), rest, value, f'{name}.')          # the path and value, checked
        except ParameterError as exc:
            raise ConfigError(f'scene {self.name}: {exc}') from None
        nested: dict[str, Any] = {}
        here = nested
        parts = rest.split('.')
        for part in parts[:-1]:
            here = here.setdefault(part, {})
        here[parts[-1]] = value
        deep_merge(self.parameters.setdefault(name, {}), nested)
        check_plugins(self.settings(), f'scene {self.name}')     # the whole, checked


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
        raise ConfigError(f'{where}: key {key!r} must be {text}, got {shorten(value)}')
    return value


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
        text = read_text(path)
        return _parse_scene(path, parse_yaml(text, str(path)), text)
    except ConfigError:
        raise
    except ParameterError as exc:
        raise ConfigError(str(exc)) from None


def _parse_scene(path: pathlib.Path, data: dict[str, Any], text: str) -> Scene:
    where = f'scene {path.name}'
    for old, why in GONE.items():
        if old in data:
            raise ConfigError(f'{where}: key {old!r} is gone ({why})')
    check_known(data, SCENE_KEYS, where)
    nodes = _typed(where, data, 'nodes')
    if not nodes:
        raise ConfigError(f'{where}: nodes is empty: name the nodes the run brings up (e.g. '
                          '[valve_1, muscle_1, load_cell_1, encoder, loading_servo, sequencer, '
                          'recorder])')
    for n in nodes:
        if n not in SCENE_NODES:
            near = nearest(str(n), SCENE_NODES)
            raise ConfigError(f'{where}: unknown node {shorten(n)}'
                              + (f' (did you mean {near!r}?)' if near else ''))
        if nodes.count(n) > 1:
            raise ConfigError(f'{where}: node {n!r} is named {nodes.count(n)} times in nodes')
    step = _typed(where, data, 'exchange_step_s')
    if not 0 < step <= 10:
        raise ConfigError(f'{where}: exchange_step_s {step} out of (0, 10] s')
    sub = _typed(where, data, 'sub_step_s', SUB_STEP_S)
    if not 1e-5 <= sub <= 1.0:
        raise ConfigError(f'{where}: sub_step_s {sub} out of [1e-5, 1] s')
    duration = _typed(where, data, 'duration_s', 0.0)
    if duration < 0:
        raise ConfigError(f'{where}: duration_s {duration} is negative')
    if not duration and not {'sequencer', 'torque_servo'} & set(nodes):
        raise ConfigError(f'{where}: nothing ends the run: add a sequencer (its protocol ends '
                          'it) or a torque_servo, or set duration_s')
    parameters = dict(_typed(where, data, 'parameters', {}))
    try:
        check_known(parameters, [*nodes, 'sim_clock'], f'{where}, parameters')
    except ParameterError as exc:
        raise ConfigError(str(exc)) from None
    for name, values in parameters.items():
        if not isinstance(values, dict):
            raise ConfigError(f'{where}: parameters.{name} must be a mapping, got '
                              f'{shorten(values)}')
    protocol = _typed(where, data, 'protocol', '')
    overrides = dict(_typed(where, data, 'protocol_overrides', {}))
    if 'sequencer' in nodes:
        try:
            protocol_schedule(protocol, overrides)      # every value, before anything starts
        except ParameterError as exc:
            raise ConfigError(f'{where}: {exc}') from None
    try:
        faults = parse_faults(_typed(where, data, 'faults', []), list(nodes))
    except ParameterError as exc:
        raise ConfigError(f'{where}: {exc}') from None
    scene = Scene(path.stem, _typed(where, data, 'description', ''), float(step), protocol,
                  list(nodes), float(duration), parameters, overrides, float(sub),
                  _typed(where, data, 'record_samples', False),
                  text, faults)
    _check_settings(scene, where)
    return scene


DEFAULT_LAW = 'bench_mckibben'
"""``muscle.law``'s default: a scene that names another law must hold it (``kind: law``)."""


def law_notes(settings: dict[str, Any]) -> list[str]:
    """One line per force law a muscle of the run holds that runs interpreted though it was
    to run compiled, and why (``models.laws.base.law_function``): said once at the start of a
    run. A law the scene runs interpreted (``muscle.law_core``) is not compiled to find out."""
    from pam_bench.models.laws.base import law_function
    from pam_bench.models.laws.zoo import force_law
    laws = sorted({st.muscle.law for name, st in settings.items()
                   if name.startswith('muscle_') and st.muscle.kind == 'law'
                   and st.muscle.law_core != 'interpreted'})
    notes = []
    for name in laws:
        why = law_function(force_law(name))[1]
        if why:
            notes.append(f'force law {name} runs interpreted, several times slower than a '
                         f'compiled one: {why} (docs/plugins.md, "What makes a law compile")')
    return notes


def _check_inputs(scene: str, settings: dict[str, Any]) -> None:
    """What the settings name besides plain values, read now rather than by a node once the
    run has started: the sequencer's suspender rules, the torque servo's inverse model file, the
    force law a muscle holds.

    Raises:
        ConfigError: a bad rule or an unreadable or malformed model, named.
    """
    from pam_bench.control.inverse import InverseModel
    from pam_bench.models.errors import ModelError
    from pam_bench.models.laws.zoo import force_law
    from pam_bench.protocol.suspenders import parse_rules
    from pam_bench.vocabulary.errors import InputError
    from pam_bench.vocabulary.yaml_io import load_yaml
    try:
        seq = settings.get('sequencer')
        if seq is not None and seq.suspenders_yaml:
            parse_rules(load_yaml(seq.suspenders_yaml, 'sequencer.suspenders_yaml'))
        servo = settings.get('torque_servo')
        if servo is not None and servo.inverse_model_file:
            InverseModel.load(servo.inverse_model_file)
        for name, st in settings.items():
            if not name.startswith('muscle_'):
                continue
            if st.muscle.kind == 'law':
                force_law(st.muscle.law)
            elif st.muscle.law != DEFAULT_LAW:     # a law named is held only with kind law
                raise ParameterError(
                    f'{name}.muscle.law {st.muscle.law!r} names a force law, but '
                    f'{name}.muscle.kind is {st.muscle.kind!r}: set {name}.muscle.kind=law '
                    'as well (or leave muscle.law out)')
            elif st.muscle.law_core != 'auto':     # so is how a law runs
                raise ParameterError(
                    f'{name}.muscle.law_core {st.muscle.law_core!r} says how a force law runs, '
                    f'but {name}.muscle.kind is {st.muscle.kind!r}: set {name}.muscle.kind=law '
                    'as well (or leave muscle.law_core out)')
    except (ParameterError, InputError, ModelError) as exc:
        raise ConfigError(f'scene {scene}: {exc}') from None


def _check_settings(scene: Scene, where: str) -> None:
    """Build every node's settings once, so that a bad key fails at load, and the plug-ins
    the scene names, so that one that cannot run fails before any node starts."""
    try:
        settings = scene.settings()
    except ConfigError as exc:
        raise ConfigError(str(exc).replace(f'scene {scene.name}:', f'{where}:', 1)) from None
    check_plugins(settings, where)


def check_plugins(settings: dict[str, Any], where: str) -> None:
    """Build the controller plug-in the torque servo names, with its settings.

    Raises:
        ConfigError: it does not load or cannot be built (its one line).
    """
    from pam_bench.control.plugins import PluginFault, check_controller
    ts = settings.get('torque_servo')
    if ts is None:
        return
    try:
        check_controller(ts.controller, ts.servo, getattr(ts.plugins, ts.controller, None))
    except PluginFault as exc:
        raise ConfigError(f'{where}: {exc}') from None


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
        check_known(params, SCENE_NODES, f'{where}, parameters')
        for name, values in params.items():
            from_mapping(NODES[name].settings, values, f'{name}.')
    except ParameterError as exc:
        raise ConfigError(f'{where}: {exc}' if not str(exc).startswith(where) else str(exc)
                          ) from None
    for name in scene.nodes:
        if name in params:
            merged = copy.deepcopy(params[name])
            deep_merge(merged, scene.parameters.get(name, {}))
            scene.parameters[name] = merged
    _check_settings(scene, where)
