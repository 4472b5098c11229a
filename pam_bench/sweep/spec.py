"""A sweep file, read strictly, and the jobs it stands for.

A sweep (YAML) names:

- ``scene``: a scene (name or path), or a list of them;
- ``engine``: ``twin`` (the numpy engines, no ROS) or ``ros`` (the nodes composed);
- ``seeds``: the sensor-noise seeds, a list (default ``[0]``);
- what to vary, by settings path (``muscle_1.muscle.gain_exponent``, ``torque_servo.servo.
  kp_v_per_n``; ``pam-bench params SCENE`` lists them), one of: ``grid`` (path -> values,
  every combination), ``list`` (a list of path -> value mappings) or ``random`` (``n`` draws,
  uniform in ``ranges``: path -> [low, high], from ``seed``; an integer setting is rounded);
- ``figures``: what to collect, by dotted key: of the extraction's summary.json
  (``isometric.gain_N_per_V.max``, ``step_response.polynomials.b.coefficients_low_to_high.0``),
  of the servo's tracking (``servo.rms_error``), of a calibration of the run's readings
  (``calibrate.values.gain_n_per_pa``, ``calibrate.stderr.gain_n_per_pa``), of the run's
  readings (``readings.force_max_N``, ``readings.contraction_max_mm``) or of the run
  (``run.sim_s``, ``run.exit_code``);
- optional ``duration_s`` (a servo scene's sim time per job) and ``description``.

Every key, every path and every figure's first word is checked when the file loads: an unknown
one is one line naming it and the nearest known one. A job is (scene, seed, the values set);
its id is stable, so a rerun skips the jobs ``results.csv`` already holds.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import pathlib
from typing import Any

import numpy as np

from pam_bench.config.errors import ConfigError
from pam_bench.config.scene import load_scene
from pam_bench.sweep.figures import check_figures
from pam_bench.vocabulary.params import check_known, hint
from pam_bench.vocabulary.run import ENGINES
from pam_bench.vocabulary.yaml_io import read_yaml

__all__ = ['Sweep', 'Job', 'load_sweep', 'FIGURE_ROOTS', 'ENGINES', 'SWEEP_KEYS']

FIGURE_ROOTS = ('isometric', 'isotonic', 'isobaric', 'step_response', 'readings', 'servo',
                'calibrate', 'run')
"""First words a figure may start with (module docstring)."""
MAX_JOBS = 100_000
"""Jobs a sweep may hold (scenes x settings x seeds)."""
MAX_DURATION_S = 86_400.0
"""Longest ``duration_s`` of a servo job, s."""
SWEEP_KEYS = ('description', 'scene', 'engine', 'seeds', 'grid', 'list', 'random', 'figures',
              'duration_s')


@dataclasses.dataclass(frozen=True)
class Job:
    """One run of a sweep: its scene, seed and the settings it sets (path -> value)."""

    scene: str
    seed: int
    values: tuple[tuple[str, Any], ...]

    @property
    def id(self) -> str:
        """A stable id of the job (the same in every rerun of the same sweep)."""
        text = json.dumps([self.scene, self.seed, [list(v) for v in self.values]],
                          sort_keys=True)
        return hashlib.sha1(text.encode()).hexdigest()[:12]


@dataclasses.dataclass
class Sweep:
    """A loaded sweep (module docstring)."""

    name: str
    scenes: list[str]
    engine: str
    seeds: list[int]
    combos: list[dict[str, Any]]
    figures: list[str]
    duration_s: float | None = None
    description: str = ''

    @property
    def paths(self) -> list[str]:
        """The settings the sweep varies, in order."""
        seen: dict[str, None] = {}
        for c in self.combos:
            seen.update(dict.fromkeys(c))
        return list(seen)

    def jobs(self) -> list[Job]:
        """Every job: scene x combination x seed, in that order."""
        return [Job(scene, seed, tuple(combo.items())) for scene in self.scenes
                for combo in self.combos for seed in self.seeds]


def _where(path: pathlib.Path) -> str:
    return f'sweep {path.name}'


def _combos(where: str, data: dict[str, Any]) -> list[dict[str, Any]]:
    given = [k for k in ('grid', 'list', 'random') if k in data]
    if len(given) > 1:
        raise ConfigError(f'{where}: {" and ".join(given)}: give one way to vary')
    if not given:
        return [{}]
    kind = given[0]
    spec = data[kind]
    if kind == 'grid':
        if not isinstance(spec, dict) or not spec:
            raise ConfigError(f'{where}: grid must map each path to a list of values')
        for path, values in spec.items():
            if not isinstance(values, list) or not values:
                raise ConfigError(f'{where}: grid.{path} must be a list of values')
        paths = list(spec)
        if math.prod(len(v) for v in spec.values()) > MAX_JOBS:
            raise ConfigError(f'{where}: the grid holds more than {MAX_JOBS} combinations')
        return [dict(zip(paths, vals, strict=True))
                for vals in itertools.product(*(spec[p] for p in paths))]
    if kind == 'list':
        if not isinstance(spec, list) or not all(isinstance(c, dict) for c in spec):
            raise ConfigError(f'{where}: list must be a list of path -> value mappings')
        return [dict(c) for c in spec]
    if not isinstance(spec, dict):
        raise ConfigError(f'{where}: random must hold n, seed and ranges')
    try:
        check_known(spec, ('n', 'seed', 'ranges'), f'{where}, random')
    except ConfigError:
        raise
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    n, seed, ranges = spec.get('n'), spec.get('seed', 0), spec.get('ranges')
    if (not isinstance(n, int) or isinstance(n, bool) or not 1 <= n <= MAX_JOBS
            or not isinstance(seed, int) or isinstance(seed, bool) or seed < 0):
        raise ConfigError(f'{where}: random.n must be an integer in [1, {MAX_JOBS}], '
                          'random.seed a non-negative integer')
    if not isinstance(ranges, dict) or not ranges:
        raise ConfigError(f'{where}: random.ranges must map each path to [low, high]')
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        combo = {}
        for path, lohi in ranges.items():
            if not (isinstance(lohi, list) and len(lohi) == 2 and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) for v in lohi)):
                raise ConfigError(f'{where}: random.ranges.{path} must be [low, high]')
            lo, hi = lohi
            v = float(rng.uniform(lo, hi))
            combo[path] = int(round(v)) if isinstance(lo, int) and isinstance(hi, int) else v
        out.append(combo)
    return out


def _check_paths(where: str, scenes: list[str], combos: list[dict[str, Any]]) -> None:
    """Every path exists in every scene and every value fits its setting (named)."""
    for name in scenes:
        scene = load_scene(name)
        for combo in combos:
            for path, value in combo.items():
                try:
                    scene.set(path, value)
                except ConfigError as exc:
                    text = str(exc).split(': ', 1)[-1]
                    raise ConfigError(f'{where}: {text}') from None


def _check_figures(where: str, figures: Any) -> list[str]:
    if not isinstance(figures, list) or not figures or not all(
            isinstance(f, str) for f in figures):
        raise ConfigError(f'{where}: figures must be a list of dotted keys')
    for f in figures:
        root = f.split('.', 1)[0]
        if root not in FIGURE_ROOTS:
            raise ConfigError(f"{where}: unknown figure '{f}' ({hint(root, FIGURE_ROOTS)})")
    check_figures(where, list(figures))
    return list(figures)


def load_sweep(path: str | pathlib.Path) -> Sweep:
    """Read a sweep file strictly (module docstring).

    Raises:
        ConfigError: an unknown key, path or figure (named, with the nearest known one), a
            value of the wrong type or out of its setting's range.
    """
    p = pathlib.Path(path)
    where = _where(p)
    data = read_yaml(p)
    try:
        check_known(data, SWEEP_KEYS, where)
    except ConfigError:
        raise
    except ValueError as exc:
        raise ConfigError(str(exc)) from None
    if 'scene' not in data:
        raise ConfigError(f"{where}: missing key 'scene'")
    scenes = data['scene'] if isinstance(data['scene'], list) else [data['scene']]
    if not all(isinstance(s, str) for s in scenes):
        raise ConfigError(f'{where}: scene must be a scene name or a list of them')
    engine = data.get('engine', 'twin')
    if engine not in ENGINES:
        raise ConfigError(f'{where}: engine {engine!r} ({hint(str(engine), ENGINES)})')
    seeds = data.get('seeds', [0])
    if not isinstance(seeds, list) or not seeds or not all(
            isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds):
        raise ConfigError(f'{where}: seeds must be a list of non-negative integers')
    duration = data.get('duration_s')
    if duration is not None and (isinstance(duration, bool)
                                 or not isinstance(duration, (int, float))
                                 or not 0 < duration <= MAX_DURATION_S):
        raise ConfigError(f'{where}: duration_s must be a number of seconds in (0, '
                          f'{MAX_DURATION_S:g}]')
    if len(seeds) > MAX_JOBS:
        raise ConfigError(f'{where}: {len(seeds)} seeds (a sweep runs at most {MAX_JOBS} jobs)')
    combos = _combos(where, data)
    if len(combos) * len(seeds) * len(scenes) > MAX_JOBS:
        raise ConfigError(f'{where}: {len(combos) * len(seeds) * len(scenes)} jobs (at most '
                          f'{MAX_JOBS})')
    _check_paths(where, scenes, combos)
    figures = _check_figures(where, data.get('figures'))
    return Sweep(p.stem, scenes, engine, list(seeds), combos, figures,
                 float(duration) if duration is not None else None,
                 str(data.get('description', '')))
