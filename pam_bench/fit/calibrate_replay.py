"""Replaying a lab's recordings on the simulated bench: what the bag calibration compares.

The observations are what the extraction reads from the bags (``bags.bagread``): every
static reading in time order (isometric: force at held x and u; isotonic: contraction at held
load and u; isobaric: contraction at held u and set load) and every step record (force
samples after a valve step at held x). The prediction replays the static readings in order on
one bench, so the friction follows the recorded path, in one of two ways (``replay``):
- 'stepped' (the default): the time-stepped bench (``twin.bench``, 004's drive) for 004's
  3 s dwell per reading, the first ``TRANSIENT_S`` at the bench's sub-step and the slow
  settling of the drive's integral action at ``SETTLE_SUB_STEP_S`` (the sub-step law is
  implicit, so the longer step stays stable). The drive's force loop, speed limit, inertia
  and gear play decide where inside its friction loop a muscle stops after a new set value,
  and the position loop's transient shakes the friction at the first pressure of an isometric
  series (the readings' exchanges as one compiled call where it applies:
  ``twin.bench_holds``, the same steps). The step records follow on the same bench (004's
  campaign runs the step responses last): each settles at its start voltage and held x for
  the dwell, then the valve steps and the bench is compared at every ``RECORD_STRIDE``-th
  sample period, run in sub-steps of the record's own sample period (as the bench records
  one), shorter where the valve's loop asks (omega_n h at most ``RECORD_OMEGA_H``;
  ``record_sub_step_s``). How the two sub-steps were chosen: docs/long_runs.md, 'Calibrate:
  how the fit's rules were chosen';
- 'static': the quasi-static bench (``twin.quasistatic``) with the valve's overshoot turning
  points, the muscle end following the belt stretch at each; an ideal drive; each step
  record from its own settled start, the valve's pressure loop integrated exactly (ZOH)
  every ``RECORD_STRIDE``-th sample period. About four times faster, and the choice for a
  bench whose drive is not 004's.

The bench replayed is a ``Bench``: valve, muscle, loading drive and, for a muscle that holds a
force law of the zoo or a plug-in (``muscle.kind: law``), the laws' parameters. Residuals are
scaled to the bench's tolerances (issue 18): forces in units of 1 % of the load cell's 2000 N
range (``FORCE_SCALE_N``), contractions in ``CONTRACTION_SCALE_M``. Readings whose friction
loop is wider than ``PATH_WIDTH_M`` (``path_sensitive``) are left out: where a transient
leaves the muscle inside such a loop is not something a replay can say.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from pam_bench.bags.bagread import BagData
from pam_bench.models import jit
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.coupling import SETTLE_OFF
from pam_bench.models.errors import ModelError
from pam_bench.models.loading_servo import LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.bench import SingleMuscleBench
from pam_bench.twin.bench_holds import run_holds, run_steps
from pam_bench.twin.quasistatic import QuasiStaticBench

__all__ = ['Observations', 'Bench', 'observations_from_bags', 'observations_from_twin',
           'predict', 'path_sensitive', 'residuals', 'rms_of', 'rms_by_kind', 'REPLAYS',
           'FORCE_SCALE_N', 'CONTRACTION_SCALE_M', 'RECORD_STRIDE', 'PATH_WIDTH_M',
           'record_sub_step_s']

FORCE_SCALE_N = 20.0            # 1 % of the load cell's range
CONTRACTION_SCALE_M = 0.5e-3
RECORD_STRIDE = 10
RECORD_OMEGA_H = 1.0             # omega_n h of a record's sub-step, at most (docstring)
REPLAYS = ('stepped', 'static')
DWELL_S = 3.0                   # 004's dwell
TRANSIENT_S = 1.0               # at the bench's sub-step, then the slow settling
SETTLE_SUB_STEP_S = 0.005
PHASES = ((TRANSIENT_S, TRANSIENT_S, SUB_STEP_S),
          (DWELL_S - TRANSIENT_S, DWELL_S, SETTLE_SUB_STEP_S))
"""A reading's dwell as (duration s, longest exchange s, sub-step s) (module docstring)."""
PATH_WIDTH_M = 8.0e-3           # friction loop wider than 16 contraction tolerances
PATH_PROBE_N = 100.0            # load offset the loop's two sides are approached from


@dataclasses.dataclass(frozen=True)
class Bench:
    """The bench a replay runs: valve, muscle, loading drive (None: 004's) and the force laws'
    parameters (``config.settings.LawSettings``; None: each law's defaults)."""

    valve: ValveParams
    muscle: MuscleParams
    servo: LoadingServoParams | None = None
    laws: Any = None


@dataclasses.dataclass
class Observations:
    """Readings in time order and step records, as the fit needs them (SI units).

    ``readings``: (kind, u V, held or set load N or held x m, measured value: F N for
    isometric, x m otherwise); ``records``: (x m, u0 V, u1 V, period s, force samples N).
    """

    readings: list[tuple[str, float, float, float]]
    records: list[tuple[float, float, float, float, np.ndarray]]
    left_aside: tuple[str, ...] = ()
    """Protocols of the bags whose readings no replay places, each with why (one line)."""


def observations_from_bags(data: BagData) -> Observations:
    """The static readings and step records of bags read by ``bags.bagread``: every protocol
    whose readings hold a contraction or a force while the voltage moves, or sweep the load at
    a held voltage, whatever its name (``analysis.static.kind_of``). A protocol of kind
    ``ramp`` (the README demo's) is set aside and named in ``left_aside``: its readings are
    taken while the voltage moves, the replay settles each reading at its voltage. So are the
    readings of a ``step_response`` protocol, each record's settled start: the replay compares
    the records from their own settled starts after the static readings (as
    ``observations_from_twin`` leaves them out); replayed as isometric readings in between,
    they sent the default bench's own campaign_quick bag 1.2 N off at its true parameters."""
    from pam_bench.analysis.static import kind_of
    from pam_bench.config.protocols import load_protocols
    table = load_protocols()
    rows = []
    aside = []
    for name, p in data.points.items():
        kind = kind_of(p)
        declared = (table.get(name) or {}).get('kind')
        if declared == 'ramp':
            aside.append(f'{name} ({len(p)} readings): a ramp, its readings taken while the '
                         'voltage moves')
            continue
        if declared == 'step_response':
            aside.append(f"{name} ({len(p)} readings): the step records' settled starts, "
                         'compared in the records themselves')
            continue
        if kind is None:
            aside.append(f'{name} ({len(p)} readings): neither the contraction nor the force '
                         'held while the voltage moves, nor the load swept at a held voltage')
            continue
        for i in range(len(p)):
            if kind == 'isometric':
                rows.append((p.t_s[i], kind, p.voltage_v[i], p.series_value[i], p.force_n[i]))
            elif kind == 'isotonic':
                rows.append((p.t_s[i], kind, p.voltage_v[i], p.series_value[i],
                             p.contraction_m[i]))
            else:
                rows.append((p.t_s[i], kind, p.voltage_v[i], p.set_value[i],
                             p.contraction_m[i]))
    rows.sort(key=lambda r: r[0])
    recs = [(r.contraction_m, r.voltage_initial_v, r.voltage_final_v, r.sample_period_s,
             np.asarray(r.force_n, float)) for r in data.records]
    return Observations([(k, float(u), float(h), float(v)) for _, k, u, h, v in rows], recs,
                        tuple(aside))


def observations_from_twin(points: Sequence[Any], records: Sequence[Any]) -> Observations:
    """The same from a numpy-twin run (``twin.protocol_run.TwinRun.points`` / ``records``)."""
    rows = []
    for pt in points:
        r = pt.reading
        kind = next((k for k in ('isometric', 'isotonic', 'isobaric')
                     if r.protocol.startswith(k)), None)
        if kind is None or not r.recorded or r.record_s > 0.0:
            continue
        value = pt.measurement.force_n if kind == 'isometric' else pt.measurement.contraction_m
        rows.append((kind, float(pt.voltage_v), float(r.load_value), float(value)))
    recs = [(rec.reading.load_value, rec.reading.pre_voltage_v, rec.reading.voltage_v,
             rec.reading.sample_period_s, np.asarray(rec.samples, float)) for rec in records]
    return Observations(rows, recs)


def _replay_stepped(obs: Observations, bench: Bench) -> tuple[np.ndarray, list[np.ndarray]]:
    """The static readings, then the step records, in order on one time-stepped bench
    (module docstring)."""
    # every sub-step solved: a held span starts where a tolerance test flips, a step the
    # finite-difference Jacobian would read as the parameters' effect
    twin = SingleMuscleBench(bench.valve, bench.muscle, LoadCellParams(noise=False),
                             servo=bench.servo, settle=SETTLE_OFF, laws=bench.laws)

    def settle(mode: LoadMode, voltage_v: float, held: float) -> None:
        if run_holds(twin, [(voltage_v, mode, held)], PHASES, [True]) is not None:
            return                                            # compiled (twin.bench_holds)
        twin.command_valve(voltage_v)
        twin.command_load(mode, held)
        for duration, h_s, sub_step_s in PHASES:
            twin.sub_step_s = sub_step_s
            twin.run(duration, h_s)

    position = [kind == 'isometric' for kind, _, _, _ in obs.readings]
    out = run_holds(twin, [(u, LoadMode.POSITION if pos else LoadMode.FORCE, held) for
                           (_, u, held, _), pos in zip(obs.readings, position, strict=True)],
                    PHASES, position)
    if out is None:                                           # the Python bench
        out = np.empty(len(obs.readings))
        for i, ((_, u, held, _), pos) in enumerate(zip(obs.readings, position, strict=True)):
            settle(LoadMode.POSITION if pos else LoadMode.FORCE, u, held)
            out[i] = twin.f if pos else twin.servo.angle * twin.servo.r
    recs = []
    for x, u0, u1, period, samples in obs.records:
        settle(LoadMode.POSITION, u0, x)
        twin.command_valve(u1)
        h = period * RECORD_STRIDE
        twin.sub_step_s = record_sub_step_s(period, bench.valve.natural_frequency_rad_s)
        first = twin.f
        n = len(samples[::RECORD_STRIDE]) - 1
        after = run_steps(twin, n, h, twin.sub_step_s)
        if after is None:                                     # the Python bench
            after = np.empty(n)
            for k in range(n):
                twin.step(h)
                after[k] = twin.f
        recs.append(np.concatenate([[first], after]))
    return out, recs


def record_sub_step_s(period_s: float, omega_rad_s: float) -> float:
    """The sub-step a step record is replayed at (s): its sample period, shorter where the
    valve's loop asks (omega_n h at most ``RECORD_OMEGA_H``), a whole fraction of the
    ``RECORD_STRIDE`` sample periods between compared samples (module docstring)."""
    h = period_s * RECORD_STRIDE
    return h / max(RECORD_STRIDE, math.ceil(h * omega_rad_s / RECORD_OMEGA_H))


def _replay_static(obs: Observations, bench: Bench) -> tuple[np.ndarray, list[np.ndarray]]:
    """The static readings in order on one quasi-static bench, each step record from its own
    settled start (module docstring)."""
    qs = QuasiStaticBench(bench.valve, bench.muscle, bench.servo, overshoot=True,
                          laws=bench.laws)
    out = np.empty(len(obs.readings))
    for i, (kind, u, held, _) in enumerate(obs.readings):
        if kind == 'isometric':
            out[i] = qs.hold_position(u, held).force_n
        else:
            out[i] = qs.hold_force(u, held).contraction_m
    recs = []
    for x, u0, u1, period, samples in obs.records:
        b = QuasiStaticBench(bench.valve, bench.muscle, bench.servo, overshoot=True,
                             laws=bench.laws)
        n = len(samples[::RECORD_STRIDE])
        recs.append(b.step_response(x, u0, u1, n * period * RECORD_STRIDE,
                                    period * RECORD_STRIDE))
    return out, recs


def predict(obs: Observations, bench: Bench, replay: str = 'stepped'
            ) -> tuple[np.ndarray, list[np.ndarray]]:
    """(predicted reading values, predicted record samples); ``replay``: 'stepped' or
    'static' (module docstring).

    Raises:
        ModelError: an unknown ``replay``.
    """
    if replay not in REPLAYS:
        raise ModelError(f'unknown replay {replay!r}: one of {", ".join(REPLAYS)}')
    _compiled_core()
    return (_replay_stepped if replay == 'stepped' else _replay_static)(obs, bench)


def _compiled_core() -> None:
    """A replay is thousands of long exchanges: load the compiled core now (in each process
    that evaluates; the reference runs where it does not load)."""
    try:
        jit.warm_up()
    except RuntimeError:
        pass


def path_sensitive(obs: Observations, bench: Bench) -> list[int]:
    """Indices of the readings at held load whose friction loop is wider than
    ``PATH_WIDTH_M`` (module docstring): the contraction at (u, F) reached from F +
    ``PATH_PROBE_N`` against from F - ``PATH_PROBE_N`` (at least 0), each on a fresh bench."""
    out, width = [], {}
    for i, (kind, u, held, _) in enumerate(obs.readings):
        if kind == 'isometric':
            continue
        if (u, held) not in width:
            xs = []
            for start in (held + PATH_PROBE_N, max(held - PATH_PROBE_N, 0.0)):
                b = QuasiStaticBench(bench.valve, bench.muscle, bench.servo, overshoot=True,
                                     laws=bench.laws)
                b.hold_force(u, start)
                xs.append(b.hold_force(u, held).contraction_m)
            width[(u, held)] = abs(xs[0] - xs[1])
        if width[(u, held)] > PATH_WIDTH_M:
            out.append(i)
    return out


def residuals(obs: Observations, pred: tuple[np.ndarray, list[np.ndarray]],
              left_out: Sequence[int] = ()) -> np.ndarray:
    """The prediction's errors scaled to the tolerances (module docstring): the readings
    not ``left_out`` in order, then every record's samples at ``RECORD_STRIDE``."""
    values, recs = pred
    scale = np.array([FORCE_SCALE_N if k == 'isometric' else CONTRACTION_SCALE_M
                      for k, _, _, _ in obs.readings])
    measured = np.array([v for _, _, _, v in obs.readings])
    keep = np.ones(len(obs.readings), bool)
    keep[list(left_out)] = False
    parts = [((values - measured) / scale)[keep]]
    for (_, _, _, _, samples), model in zip(obs.records, recs, strict=True):
        parts.append((model - samples[::RECORD_STRIDE]) / FORCE_SCALE_N)
    return np.concatenate(parts) if parts else np.zeros(0)


def rms_by_kind(obs: Observations, bench: Bench, left_out: Sequence[int] = (),
                replay: str = 'stepped') -> dict[str, float]:
    """RMS of the prediction's error per protocol kind: N (isometric, records) or mm; the
    readings ``left_out`` do not count."""
    return rms_of(obs, predict(obs, bench, replay), left_out)


def rms_of(obs: Observations, pred: tuple[np.ndarray, list[np.ndarray]],
           left_out: Sequence[int]) -> dict[str, float]:
    """RMS of a prediction's error per protocol kind (N or mm), the ``left_out`` readings
    left out."""
    values, recs = pred
    out = {}
    for kind in ('isometric', 'isotonic', 'isobaric'):
        idx = [i for i, r in enumerate(obs.readings) if r[0] == kind and i not in left_out]
        if idx:
            err = values[idx] - np.array([obs.readings[i][3] for i in idx])
            out[kind] = float(np.sqrt(np.mean(err ** 2)) * (1.0 if kind == 'isometric'
                                                              else 1e3))
    if recs:
        err = np.concatenate([m - r[4][::RECORD_STRIDE]
                              for m, r in zip(recs, obs.records, strict=True)])
        out['step_records'] = float(np.sqrt(np.mean(err ** 2)))
    return out
