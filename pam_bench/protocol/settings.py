"""Settings of a protocol run: the abort limits of the sequencer and the runner's policies.

One field per setting (``vocabulary.params.field``): the sequencer node declares its ROS parameters
from these classes and the twin runs with the same objects, so a default lives here only.
"""

from __future__ import annotations

import dataclasses

from pam_bench.models.constants import LOAD_CELL_RANGE_N
from pam_bench.vocabulary.params import field

__all__ = ['Limits', 'RunnerSettings', 'COMMAND_STEP_S', 'RECORD_EXCHANGE_S', 'PAUSE_ACTIONS',
           'OUTLIER_ACTIONS']

# exchange steps a lock-step sequencer asks for: at every new reading or phase (the loading
# servo takes a new set value one exchange after it is sent), and at most during a 1 kHz record
# (the valve holds the chamber volume of an exchange's start, which moves the fitted b, c, d the
# more the longer the exchange: BENCHMARKS.md, 'Step records')
COMMAND_STEP_S = 0.001
RECORD_EXCHANGE_S = 0.05
PAUSE_ACTIONS = ('hold', 'vent')
OUTLIER_ACTIONS = ('report', 'suspend')


@dataclasses.dataclass
class Limits:
    """Abort thresholds: load-cell range (N), set-value tolerances of the loading servo at a
    reading (N, m; the force tolerance also relative), and the valve check: the gauge pressure
    at a reading within ``pressure_tolerance_pa`` of k_v u (a stuck valve; 0: no check; not on
    ramp readings, taken while the voltage moves)."""

    force_range_n: float = field(LOAD_CELL_RANGE_N, 'N', 'load cell range: abort beyond',
                                 1.0, 1e6)
    force_tolerance_n: float = field(10.0, 'N', 'servo force tolerance at a reading', 0.0, 1e5)
    force_tolerance_rel: float = field(0.05, '-', 'relative force tolerance', 0.0, 1.0)
    position_tolerance_m: float = field(1.0e-3, 'm', 'servo position tolerance at a reading',
                                        0.0, 1.0)
    pressure_tolerance_pa: float = field(0.0, 'Pa', 'abort when the valve pressure at a reading '
                                         'is further than this from k_v u (a stuck valve); 0: '
                                         'off', 0.0, 1e7)
    valve_gain_pa_per_v: float = field(1.0e5, 'Pa/V', 'valve gain k_v of that check', 1.0, 1e7)

    def limits(self) -> Limits:
        """The limits alone (a ``RunnerSettings`` carries them among its other fields)."""
        return Limits(**{f.name: getattr(self, f.name) for f in dataclasses.fields(Limits)})


@dataclasses.dataclass
class RunnerSettings(Limits):
    """What the protocol runner decides besides the schedule (``protocol.runner``)."""

    status_period_s: float = field(1.0, 's', 'sim time between status messages', 1e-3, 1e6,
                                   tunable=True)
    stop_on_end: bool = field(True, '-', 'end the run with the protocol (lock-step: ask the '
                              'sim clock; wall clock: exit after end_linger_s)')
    end_linger_s: float = field(0.5, 's', 'without lock-step: time between the end of the '
                                'protocol and the exit of the node (stop_on_end)', 0.0, 60.0)
    stale_timeout_s: float = field(0.5, 's', 'abort when a measured topic is older than this '
                                   '(without lock-step)', 1e-3, 60.0, tunable=True)
    pause_action: str = field('hold', '-', "what a pause does: 'hold' the reading's set values "
                              "or 'vent' (0 V, drive off; the resume settles again)",
                              choices=PAUSE_ACTIONS)
    suspenders_yaml: str = field('', '-', 'YAML list of suspenders: {input: force | contraction '
                                 '| pressure, low, high, stale_s, resume_after_s} '
                                 '(protocol.suspenders)', tunable=True)
    reading_outliers: str = field('report', '-', "a sample of a reading's window outside a "
                                  "suspender's band is left out of the mean and 'report'ed "
                                  "with the reading (diagnostics), or 'suspend's the run",
                                  choices=OUTLIER_ACTIONS)
    record_exchange_s: float = field(RECORD_EXCHANGE_S, 's', 'longest exchange step asked for '
                                     'during a step record (0: the whole record in one; the '
                                     'devices report every sample inside it)', 0.0, 10.0)
    command_step_s: float = field(COMMAND_STEP_S, 's', 'exchange step asked for at every new '
                                  'reading or phase (the loading servo takes a new set value '
                                  'one exchange after it is sent)', 1e-6, 10.0)
