"""Verbs that design a muscle: size (000's sizing graph, forward and inverse)."""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
from typing import Any

from pam_bench.cli.errors import UsageError

__all__ = ['register']


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('size', help="000's design procedure for a straight-fibre muscle")
    p.add_argument('kind', choices=['straight-fibre'])
    p.add_argument('--diameter-mm', type=float, help='Phi0, mm (forward)')
    p.add_argument('--length-mm', type=float, help='free length L_m0, mm (forward)')
    p.add_argument('--inverse', action='store_true', help='find diameters and lengths that '
                   'contract --contraction-mm under --force-n at --pressure-mpa')
    p.add_argument('--contraction-mm', type=float, help='target contraction, mm (inverse)')
    p.add_argument('--plot', metavar='DIR', help='inverse: write the graph with the design '
                   'points as DIR/correlation_graph.png')
    p.add_argument('--segments', type=int, required=True, help='segments N + 1 (N rings)')
    p.add_argument('--wall-mm', type=float, required=True, help='wall thickness s, 1..4 mm')
    p.add_argument('--force-n', type=float, required=True, help='load F, N')
    p.add_argument('--pressure-mpa', type=float, required=True, help='gauge pressure P, MPa')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_size)


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
        print(json.dumps(out, indent=2))
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
    found = designs_for(args.force_n, args.contraction_mm * 1e-3, args.pressure_mpa * 1e6,
                        args.segments, args.wall_mm * 1e-3)
    if args.plot:
        from pam_bench.analysis.plots import plot_correlation
        out = pathlib.Path(args.plot)
        out.mkdir(parents=True, exist_ok=True)
        print(f'graph with the design points: {out / plot_correlation(found, out)}',
              file=sys.stderr)
    if args.json:
        print(json.dumps([dataclasses.asdict(d) for d in found], indent=2))
    elif not found:
        print('no design inside the correlation graph meets the target')
    for d in [] if args.json else found:
        print(f'Phi0 {d.diameter_m * 1e3:6.1f} mm  L_m0 {d.length_m * 1e3:6.1f} mm  '
              f'(L0 {d.segment_length_m * 1e3:5.1f} mm, Phi0/L0 {d.phi0_over_l0:.3f}, '
              f'P L0^2/F {d.p_l0sq_over_f:.4g})  contraction ratio {d.contraction_ratio:.4f}')
    return 0 if found else 1
