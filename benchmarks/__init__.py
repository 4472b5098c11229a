"""The benchmark studies (speed against error) and the BENCHMARKS.md report; not in the wheel.

One module per study, named as its key (``studies.STUDIES``), and the report's machinery
(``suite``, ``report``, ``tables``, ``study``). ``python -m benchmarks`` or ``make bench`` runs
them from a clone; they import pam_bench, which never imports them.
"""

from __future__ import annotations

__all__ = ['buses', 'calibrate', 'calibrate_bounds', 'calibrate_nodes', 'calibration', 'dynamics',
           'errors', 'exchange_step', 'faults', 'fidelity', 'fuzz', 'layouts', 'lockstep',
           'models', 'profile', 'record_exchange', 'report', 'runs', 'scenes', 'servo_compare',
           'settle', 'soak', 'straight_fibre', 'studies', 'study', 'suite', 'sweep_scaling',
           'tables', 'wallclock', 'work_precision']
