"""Two bags compared reading by reading: characteristic points and step records.

Points are matched by (protocol, series, step, direction), records by (series, step,
direction); per protocol the largest absolute differences of force, contraction, pressure and
voltage, and for the records the largest difference of any force sample. Two runs of the same
lock-step scene and seed give zero everywhere (the lock-step is deterministic).
"""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np

from pam_bench.bags.bagread import read_bags

__all__ = ['diff_bags']


def diff_bags(a: str | pathlib.Path, b: str | pathlib.Path) -> dict[str, Any]:
    """Per protocol: matched readings, readings in one bag only, largest differences.

    Raises:
        BagError: a bag cannot be read or holds no protocol data.
    """
    da, db = read_bags([a]), read_bags([b])
    out: dict[str, Any] = {}
    for name in sorted(set(da.points) | set(db.points)):
        pa, pb = da.points.get(name), db.points.get(name)
        ka = {} if pa is None else {(int(pa.series[i]), int(pa.step[i]), int(pa.direction[i])): i
                                    for i in range(len(pa.t_s))}
        kb = {} if pb is None else {(int(pb.series[i]), int(pb.step[i]), int(pb.direction[i])): i
                                    for i in range(len(pb.t_s))}
        common = sorted(set(ka) & set(kb))
        row: dict[str, Any] = {'matched': len(common), 'only_a': len(set(ka) - set(kb)),
                               'only_b': len(set(kb) - set(ka))}
        for field, _unit in (('force_n', 'N'), ('contraction_m', 'm'), ('pressure_pa', 'Pa'),
                            ('voltage_v', 'V')):
            d = [abs(float(getattr(pa, field)[ka[k]]) - float(getattr(pb, field)[kb[k]]))
                 for k in common]
            row[f'max_{field}'] = max(d) if d else 0.0
        row['units'] = 'N, m, Pa, V'
        out[name] = row
    ra = {(r.series, r.step, r.direction): r for r in da.records}
    rb = {(r.series, r.step, r.direction): r for r in db.records}
    if ra or rb:
        common = sorted(set(ra) & set(rb))
        worst = 0.0
        for k in common:
            fa, fb = ra[k].force_n, rb[k].force_n
            n = min(len(fa), len(fb))
            if len(fa) != len(fb):
                worst = float('inf')
            if n:
                worst = max(worst, float(np.max(np.abs(fa[:n] - fb[:n]))))
        out['step_response_records'] = {'matched': len(common),
                                        'only_a': len(set(ra) - set(rb)),
                                        'only_b': len(set(rb) - set(ra)),
                                        'max_force_n': worst}
    return out
