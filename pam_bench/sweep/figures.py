"""Which figures a sweep job can give: every name checked before any job runs.

A figure is a dotted path into a job's result (``sweep.jobs``). The protocol namespaces
(``isometric``, ``isotonic``, ``isobaric``, ``step_response``) are the
extraction's estimators, so their paths are read off one probe: the twin's ``campaign_quick``
(every protocol kind, a couple of seconds, once per process). The others are the producers'
own keys: ``servo.*`` (``twin.servo_bench.tracking_metrics``), ``readings.*`` and ``run.*``
(``sweep.jobs``), and ``calibrate.*`` (``fit.calibrate_bags``: every free parameter's value
and standard error, the RMS per protocol, the cost, the evaluations). A list's items are
addressed by index (``step_response.fits.0.b``). A name that fits none is one ``ConfigError``
naming the nearest that does.
"""

from __future__ import annotations

import functools
from typing import Any

from pam_bench.config.errors import ConfigError
from pam_bench.vocabulary.params import nearest

__all__ = ['known_figures', 'check_figures', 'PROBE_SCENE', 'SERVO_KEYS', 'READINGS_KEYS',
           'RUN_KEYS']

PROBE_SCENE = 'campaign_quick'
"""The scene whose twin run shows the protocol namespaces' paths."""
SERVO_KEYS = ('rms_error', 'max_error', 'error_at_reversal', 'error_elsewhere',
              'reversal_window_s')
"""``servo.*``: the numbers ``tracking_metrics`` returns."""
READINGS_KEYS = ('force_max_N', 'contraction_max_mm')
RUN_KEYS = ('sim_s', 'exit_code')
_INDEX = '#'


def _paths(here: Any, prefix: str, out: set[str]) -> None:
    if isinstance(here, dict):
        for k, v in here.items():
            _paths(v, f'{prefix}{k}.', out)
    elif isinstance(here, list):
        for item in here:
            _paths(item, f'{prefix}{_INDEX}.', out)
    elif isinstance(here, (int, float)) and not isinstance(here, bool):
        out.add(prefix[:-1])


@functools.lru_cache(maxsize=1)
def _protocol_paths() -> frozenset[str]:
    from pam_bench.analysis.extract import step_summary
    from pam_bench.analysis.static import gain_summary
    from pam_bench.config.scene import load_scene
    from pam_bench.twin.protocol_run import bag_data_of, run_scene
    data = bag_data_of(run_scene(load_scene(PROBE_SCENE), 0))
    result: dict[str, Any] = dict(gain_summary(data.points))
    result['step_response'] = step_summary(data.records)
    out: set[str] = set()
    _paths(result, '', out)
    return frozenset(out)


def _calibrate_paths() -> set[str]:
    from pam_bench.fit.calibrate_bags import FREE_BAGS
    names = [n for _, n, _, _ in FREE_BAGS]
    kinds = ('isometric', 'isotonic', 'isobaric', 'step_records')
    return ({f'calibrate.values.{n}' for n in names} | {f'calibrate.stderr.{n}' for n in names}
            | {f'calibrate.rms_after.{k}' for k in kinds}
            | {'calibrate.cost', 'calibrate.evaluations'})


def known_figures(roots: set[str]) -> set[str]:
    """Every figure path of the namespaces ``roots`` (list indices as ``#``)."""
    out: set[str] = set()
    if roots & {'isometric', 'isotonic', 'isobaric', 'step_response'}:
        out |= {p for p in _protocol_paths() if p.split('.', 1)[0] in roots}
    if 'servo' in roots:
        out |= {f'servo.{k}' for k in SERVO_KEYS}
    if 'readings' in roots:
        out |= {f'readings.{k}' for k in READINGS_KEYS}
    if 'run' in roots:
        out |= {f'run.{k}' for k in RUN_KEYS}
    if 'calibrate' in roots:
        out |= _calibrate_paths()
    return out


def _pattern(name: str) -> str:
    return '.'.join(_INDEX if part.lstrip('-').isdigit() else part
                    for part in name.split('.'))


def check_figures(where: str, figures: list[str]) -> None:
    """Check every figure name against what a job can give.

    Raises:
        ConfigError: the first unknown one, with the nearest known name.
    """
    known = known_figures({f.split('.', 1)[0] for f in figures})
    for f in figures:
        if _pattern(f) not in known:
            near = nearest(_pattern(f), known)
            shown = near.replace(_INDEX, '0') if near else None
            raise ConfigError(f"{where}: unknown figure '{f}'"
                              + (f" (did you mean '{shown}'?)" if shown else ''))
