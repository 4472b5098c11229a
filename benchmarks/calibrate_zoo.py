"""Study ``calibrate_zoo``: bags made with each force law of the zoo, calibrated with that law
and with the bench's McKibben law (issue 55, 'An honest verdict').

For every law of the zoo (000's straight-fibre law aside: it needs its own muscle, study
``straight_fibre``) and ``SEEDS``: isometric_quick over 0 to 4 V in 0.5 V steps at x = 0, 40
and 80 mm (``OVERRIDES``) on the numpy twin, the muscle that law at its defaults
(``muscle.kind: law``), the load cell's noise on; ``calibrate_bags(law=...)`` on its readings as
``pam-bench calibrate --law`` runs it; on the first seed's bag also the bench's own law, as a lab
that did not know the law would. The bags run as jobs of the execution layer, one per worker.

Per bag: the verdict, the isometric RMS against its noise level, each of the law's parameters'
error against the law's defaults, which the fit flags, the fit's time. A false 'not converged'
is a bag fitted with its own law and not converged; a false 'converged' one fitted with its own
law, converged, with a parameter the fit reports fixed more than ``TOLERANCE`` off.
"""

from __future__ import annotations

import time
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table

__all__ = ['STUDY', 'SEEDS', 'OVERRIDES', 'one_bag', 'measure', 'section', 'results']

SEEDS = (1, 2, 3)
OVERRIDES = {'voltage_v': [0.0, 4.0, 0.5]}
TOLERANCE = 0.05
BENCH_LAW = 'the bench McKibben law'


def one_bag(job: tuple[str, int, str | None]) -> dict[str, Any]:
    """Make the bag of law ``job[0]`` with seed ``job[1]`` and calibrate it with the law
    ``job[2]`` (None: the bench's McKibben law); the row of the section."""
    from pam_bench.fit.calibrate_bags import calibrate_bags, observations_from_twin
    from pam_bench.models.laws.zoo import force_law
    from pam_bench.models.muscle import MuscleParams
    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.twin.protocol_run import run_protocol
    law, seed, fit_law = job
    run = run_protocol('isometric_quick', 3.0, overrides=OVERRIDES,
                       muscle=MuscleParams(kind='law', law=law), sub_step_s=0.005,
                       load_cell=LoadCellParams(noise=True), seed=seed)
    obs = observations_from_twin(run.points, run.records)
    t0 = time.perf_counter()
    res = calibrate_bags(obs, law=fit_law)
    the_law = force_law(law)
    errors: dict[str, float] = {}
    if fit_law is not None:
        for n, truth in zip(the_law.params, the_law.start, strict=True):
            value = res['values'][f'{law}.{n}']
            errors[n] = (value - truth) / truth if truth else value
    v = res['verdict']
    return {'law': law, 'seed': seed, 'fit': fit_law or BENCH_LAW,
            'converged': v['converged'], 'rms': v['rms'], 'tolerance': v['tolerance'],
            'zero': [n for n, t in zip(the_law.params, the_law.start, strict=True) if not t],
            'errors': errors, 'flags': [f.split('.', 1)[-1] for f in res['flags']],
            'fixed': len(res['names']) - len(res['flags']), 'advice': v['advice'],
            'fit_s': time.perf_counter() - t0, 'evaluations': res['evaluations']}


def measure(quick: bool) -> dict[str, Any]:
    """Every bag (module docstring); quick: two laws, one seed."""
    from pam_bench.cluster.layer import run_jobs
    from pam_bench.models.laws.zoo import all_laws
    laws = [law.name for law in all_laws() if law.name != 'straight_fibre']
    seeds = SEEDS[:1] if quick else SEEDS
    jobs: list[tuple[str, int, str | None]] = []
    for law in laws[:2] if quick else laws:
        jobs += [(law, seed, law) for seed in seeds]
        jobs.append((law, seeds[0], None))
    rows = []
    for r in run_jobs(one_bag, jobs, label='calibrate the law zoo'):
        rows.append(r.value if r.ok else {'law': r.item[0], 'seed': r.item[1],
                                           'fit': r.item[2] or BENCH_LAW, 'failed': r.error})
    return {'bags': rows, 'tolerance': TOLERANCE}


def _error(row: dict[str, Any], n: str, e: float) -> str:
    return f'{n} {e:+.3g} (truth 0)' if n in row['zero'] else f'{n} {e * 100:+.1f} %'


def _fixed_over(row: dict[str, Any], tolerance: float) -> dict[str, float]:
    return {n: e for n, e in row['errors'].items() if n not in row['flags']
            and n not in row['zero'] and abs(e) > tolerance}


def section(r: dict[str, Any]) -> list[str]:
    """One row per bag and fit, then the false verdicts counted."""
    c = r['calibrate_zoo']
    rows: list[Row] = []
    for b in c['bags']:
        own = b['fit'] == b['law']
        if 'failed' in b:
            rows.append((b['law'], b['seed'], 'its own law' if own else BENCH_LAW,
                         f"failed: {b['failed'][:60]}", '-', '-', '-', '-'))
            continue
        fixed = {n: e for n, e in b['errors'].items() if n not in b['flags']}
        worst = max(fixed.items(), key=lambda kv: 0.0 if kv[0] in b['zero'] else abs(kv[1]),
                    default=None)
        loose = [_error(b, n, e) for n, e in b['errors'].items() if n in b['flags']]
        rows.append((b['law'], b['seed'], 'its own law' if own else BENCH_LAW,
                     'converged' if b['converged'] else '**not converged**',
                     f"{b['rms']['isometric']:.3f} / {b['tolerance']['isometric']:.3f}",
                     _error(b, *worst) if worst else '-',
                     (', '.join(loose) or '-') if own else f"{len(b['flags'])} flagged, "
                     f"{b['fixed']} fixed", f"{b['fit_s']:.0f} s"))
    lines = table(['bag made with', 'seed', 'fitted with', 'verdict',
                   'isometric RMS / noise level, N', 'largest error of a parameter reported '
                   'fixed', 'flagged not fixed: their errors', 'fit'], rows)
    counts = _counts(c)
    lines += ['', f"{counts['own']} bags fitted with their own law: {counts['false_not']} "
              f"'not converged', {counts['false_conv']} 'converged' with a parameter reported "
              f"fixed more than {c['tolerance']:.0%} off; {counts['bench']} fitted with the "
              f"bench's McKibben law: {counts['bench_not']} 'not converged'."]
    return lines


def _counts(c: dict[str, Any]) -> dict[str, int]:
    done = [b for b in c['bags'] if 'failed' not in b]
    own = [b for b in done if b['fit'] == b['law']]
    bench = [b for b in done if b['fit'] != b['law']]
    return {'own': len(own), 'false_not': sum(not b['converged'] for b in own),
            'false_conv': sum(b['converged'] and bool(_fixed_over(b, c['tolerance']))
                              for b in own),
            'bench': len(bench), 'bench_not': sum(not b['converged'] for b in bench)}


def results(r: dict[str, Any]) -> list[Row]:
    """False verdicts over the bags fitted with their own law."""
    c = r.get('calibrate_zoo')
    if not c:
        return []
    n = _counts(c)
    return [("calibrate --law on bags of that law (the zoo's, noise on): false 'not converged', "
             "false 'converged' (a parameter reported fixed more than 5 % off)", '0 and 0',
             f"{n['false_not']} and {n['false_conv']} of {n['own']}",
             commit_of(r, 'calibrate_zoo'))]


STUDY = Study(
    'calibrate_zoo', "pam-bench calibrate --law on bags of each law of the zoo, and with the "
    "bench's own law",
    lambda quick, out, scenes: {'calibrate_zoo': measure(quick)},
    (('calibrate_zoo', lambda r, root: section(r)),), results, quick=False)
"""The law zoo's round trips (bench.json ``calibrate_zoo``)."""
