"""Verbs that design: size (000's sizing graph, forward and inverse), sweep (settings over
many runs)."""

from __future__ import annotations

import argparse
import pathlib
import sys
from typing import Any

from pam_bench.cli.cluster_args import add_cluster_args, cluster_of
from pam_bench.cli.errors import UsageError
from pam_bench.cli.json_out import dumps
from pam_bench.cli.numbers import integer, number, out_path
from pam_bench.vocabulary.outputs import (
    check_output,
    claim_output,
    clear_output,
    own_files,
    resolved,
    seal_output,
    staged_output,
)

SWEEP_VERB = 'pam-bench sweep'
"""Who writes a sweep's folder (its output marker)."""

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('size', help="000's design procedure for a straight-fibre muscle")
    p.add_argument('kind', choices=['straight-fibre'])
    p.add_argument('--diameter-mm', type=number(0, 1e4, 'mm', True), help='Phi0, mm (forward)')
    p.add_argument('--length-mm', type=number(0, 1e5, 'mm', True),
                   help='free length L_m0, mm (forward)')
    p.add_argument('--inverse', action='store_true', help='find diameters and lengths that '
                   'contract --contraction-mm under --force-n at --pressure-mpa')
    p.add_argument('--contraction-mm', type=number(0, 1e5, 'mm', True),
                   help='target contraction, mm (inverse)')
    p.add_argument('--plot', type=out_path,
                   metavar='DIR', help='inverse: write the graph with the design '
                   'points as DIR/correlation_graph.png (a new folder)')
    p.add_argument('--overwrite', action='store_true', help='replace --plot, a folder pam-bench '
                   'size wrote')
    p.add_argument('--segments', type=integer(1, 1000), required=True,
                   help='segments N + 1 (N rings)')
    p.add_argument('--wall-mm', type=number(0, 100, 'mm', True), required=True,
                   help='wall thickness s, 1..4 mm')
    p.add_argument('--force-n', type=number(0, 1e6, 'N', True), required=True, help='load F, N')
    p.add_argument('--pressure-mpa', type=number(0, 100, 'MPa', True), required=True,
                   help='gauge pressure P, MPa')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_size)
    p = sub.add_parser('sweep', help='run a scene over a grid, a list or random draws of its '
                       'settings and seeds on the cluster -> results.csv and plots')
    p.add_argument('sweep', help='sweep file (config/sweeps/NAME.yaml or a path)')
    p.add_argument('--out', type=out_path,
                   required=True, help='output folder: new, or a sweep of its own, '
                   'which a rerun continues (skipping the jobs that ran)')
    p.add_argument('--overwrite', action='store_true', help='start --out, a sweep of its own, '
                   'afresh (only the files it wrote are removed)')
    p.add_argument('--no-plots', action='store_true', help='results.csv only')
    add_cluster_args(p)
    p.set_defaults(func=_cmd_sweep)


def _cmd_size(args: argparse.Namespace) -> int:
    import dataclasses

    from pam_bench.models.laws.straight_fibre import size
    if args.inverse:
        return _size_inverse(args)
    missing = [n for n in ('diameter_mm', 'length_mm') if getattr(args, n) is None]
    if missing:
        raise UsageError(f'forward sizing needs --{missing[0].replace("_", "-")} (or '
                         '--inverse --contraction-mm C)')
    r = size(args.diameter_mm * 1e-3, args.length_mm * 1e-3, args.segments,
             args.wall_mm * 1e-3, args.force_n, args.pressure_mpa * 1e6)
    out = dataclasses.asdict(r) | {'validity': {'phi0_over_l0': [0.25, 0.5],
                                                'p_l0sq_over_f': [1.2, 2880.0],
                                                'wall_mm': [1.0, 4.0]}}
    if args.json:
        print(dumps(out))
    else:
        print(f'segment L0 {r.segment_length_m * 1e3:.1f} mm, Phi0/L0 {r.phi0_over_l0:.3f}, '
              f'P L0^2/F {r.p_l0sq_over_f:.4g}: dL/L0 {r.segment_ratio:.4f} from the graph, '
              f'x {r.thickness_factor:.2f} for the wall -> contraction ratio '
              f'{r.contraction_ratio:.4f} ({r.contraction_m * 1e3:.2f} mm)')
    return 0


def _size_inverse(args: argparse.Namespace) -> int:
    import dataclasses

    from pam_bench.models.laws.straight_fibre import designs_for
    if args.contraction_mm is None:
        raise UsageError('--inverse needs --contraction-mm')
    if args.plot:
        check_output(args.plot, 'pam-bench size', args.overwrite)
    found = designs_for(args.force_n, args.contraction_mm * 1e-3, args.pressure_mpa * 1e6,
                        args.segments, args.wall_mm * 1e-3)
    if args.plot:
        from pam_bench.analysis.plots import plot_correlation
        with staged_output(args.plot, 'pam-bench size', args.overwrite) as tmp:
            name = plot_correlation(found, tmp)
        print(f'graph with the design points: {pathlib.Path(args.plot) / name}',
              file=sys.stderr)
    if args.json:
        print(dumps([dataclasses.asdict(d) for d in found]))
    elif not found:
        print('no design inside the correlation graph meets the target')
    for d in [] if args.json else found:
        print(f'Phi0 {d.diameter_m * 1e3:6.1f} mm  L_m0 {d.length_m * 1e3:6.1f} mm  '
              f'(L0 {d.segment_length_m * 1e3:5.1f} mm, Phi0/L0 {d.phi0_over_l0:.3f}, '
              f'P L0^2/F {d.p_l0sq_over_f:.4g})  contraction ratio {d.contraction_ratio:.4f}')
    return 0 if found else 1


def _cmd_sweep(args: argparse.Namespace) -> int:
    from pam_bench.config.paths import config_dir
    from pam_bench.sweep.results import RESULTS, plot_results, run_sweep
    from pam_bench.sweep.spec import load_sweep
    path = pathlib.Path(args.sweep)
    if not path.suffix:
        path = config_dir() / 'sweeps' / f'{args.sweep}.yaml'
    sweep = load_sweep(path)
    cluster = cluster_of(args)
    out = resolved(args.out)
    mine = own_files(out) if out.is_dir() else None
    again = mine is not None and mine[0] == SWEEP_VERB and not args.overwrite
    out = check_output(out, SWEEP_VERB, args.overwrite or again, [path])
    if not again:
        clear_output(out)
    claim_output(out, SWEEP_VERB)
    rows = run_sweep(sweep, out, cluster)
    failed = [r for r in rows if r['status'] != 'ok']
    for r in failed:
        print(f"job {r['job']} ({r['scene']}, seed {r['seed']}): {r['status']}")
    names = [] if args.no_plots else plot_results(sweep, rows, out)
    seal_output(out)
    print(f'{len(rows) - len(failed)} of {len(rows)} jobs ok; wrote {out / RESULTS}'
          + (f' and {len(names)} plots' if names else ''))
    return 1 if failed else 0
