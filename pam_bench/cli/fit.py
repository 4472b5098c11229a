"""Verbs that fit: extract, truth, calibration, calibrate."""

from __future__ import annotations

import argparse
import contextlib
import json
import pathlib
import sys
from typing import TYPE_CHECKING, Any

from pam_bench.cli.cluster_args import add_cluster_args, cluster_of
from pam_bench.cli.errors import UsageError
from pam_bench.cli.json_out import dumps
from pam_bench.cli.numbers import integer, number, out_path
from pam_bench.fit.calibrate_verdict import NOT_CONVERGED, Verdict
from pam_bench.vocabulary.outputs import (
    check_output_file,
    staged_output,
    write_output_file,
)

if TYPE_CHECKING:
    from pam_bench.fit.calibrate_bags import Calibration

__all__ = ['register']

VERB = 'pam-bench calibrate'
"""Who writes an overlay (its first line, ``vocabulary.outputs``)."""


def register(sub: Any) -> None:
    """Add this group's verbs to the ``pam-bench`` sub-parsers."""
    p = sub.add_parser('extract', help='bags -> characteristics, gains, identified model')
    p.add_argument('bags', nargs='+', help='rosbag2 directories')
    p.add_argument('--out', type=out_path,
                   required=True, help='output folder: new, or an extraction of its '
                   'own with --overwrite (it takes its place once complete)')
    p.add_argument('--overwrite', action='store_true', help='replace --out, an earlier '
                   'extraction (only the files it wrote)')
    p.add_argument('--each', action='store_true', help='each bag on its own into '
                   'OUT/<bag name>/ (one job per bag on the cluster), then one comparison '
                   'across them in OUT (comparison.csv, .md, drift.png)')
    add_cluster_args(p)
    p.set_defaults(func=_cmd_extract)
    p = sub.add_parser('truth', help="what the scene's parameters imply (summary.json keys)")
    p.add_argument('scene', help='scene name or scene file')
    p.add_argument('--json', action='store_true', help='print the whole JSON')
    p.add_argument('--against', help='an extraction folder or summary.json to compare with')
    p.add_argument('--no-reference', action='store_true',
                   help='skip the noise-free simulated step responses (faster)')
    p.set_defaults(func=_cmd_truth)
    p = sub.add_parser('calibration', help='figures the simulated bench implies')
    p.add_argument('--json', action='store_true')
    p.add_argument('--step', type=number(1e-5, 1.0, 's'), default=0.01, help='exchange step, s')
    p.set_defaults(func=_cmd_calibration)
    p = sub.add_parser('calibrate', help="fit the bench's muscle (and valve) to recorded bags, "
                       "or to 004's figures (--target 004)")
    p.add_argument('bags', nargs='*', help='rosbag2 folders of a campaign (static readings '
                   'and step records)')
    p.add_argument('--target', default='004', help="without bags: what to fit to (004: the "
                   "paper's figures)")
    p.add_argument('--out', type=out_path,
                   help='write the fitted parameters as an overlay (run --params)')
    p.add_argument('--overwrite', action='store_true', help='replace --out, an overlay (or '
                   'with --each a folder) that pam-bench calibrate wrote')
    p.add_argument('--max-evaluations', type=integer(1, 100_000), default=60,
                   help='largest number of residual evaluations')
    p.add_argument('--replay', choices=('stepped', 'static'), default='stepped',
                   help="bags: replay the readings on the time-stepped bench with 004's drive "
                   '(stepped) or on the quasi-static bench with an ideal drive (static, about '
                   "four times faster; for a drive that is not 004's)")
    p.add_argument('--each', action='store_true', help='bags: calibrate each bag on its own '
                   '(one job per bag on the cluster; --out is then a folder, one overlay per '
                   'bag)')
    p.add_argument('--start', choices=('data', 'defaults'), default='data',
                   help='bags: start the fit from values read off the data (default) or from '
                   "the bench's defaults")
    p.add_argument('--starts', type=integer(0, 1000), default=8,
                   help='bags: more starts spread over the fit intervals when the first fit '
                   'does not reach the noise level (0: none)')
    p.add_argument('--law', metavar='NAME', help='bags: the muscle is this force law of the zoo '
                   "(or a plug-in's; pam-bench plugins lists them) instead of the bench's "
                   'McKibben law: its parameters, the friction and the valve fitted')
    p.add_argument('--scene', metavar='SCENE', help='bags: the bench they were recorded on (a '
                   "scene's name or file, e.g. one that gives the muscle's size): every value "
                   "the fit does not free comes from its muscle, valve and drive (default: "
                   "the settings the first bag's run description holds, else the bench's "
                   "defaults)")
    p.add_argument('--json', action='store_true')
    add_cluster_args(p)
    p.set_defaults(func=_cmd_calibrate)


def _figure_table(rows: list[dict[str, Any]]) -> None:
    print(f"{'figure':48s} {'004':>9s} {'bench':>9s} {'difference':>11s} {'tolerance':>10s}")
    for r in rows:
        diff = (f"{r['difference'] * 100:+.1f} %" if r['relative']
                else f"{r['difference']:+.3g} {r['unit']}")
        tol = ('>= 004' if r['at_least'] else f"{r['tolerance'] * 100:g} %" if r['relative']
               else f"{r['tolerance']:g} {r['unit']}")
        print(f"{r['text'] + ', ' + r['unit']:48s} {r['paper']:9.4g} {r['bench']:9.4g} "
              f'{diff:>11s} {tol:>10s}  {"ok" if r["ok"] else "MISS"}')


def _cmd_calibration(args: argparse.Namespace) -> int:
    from pam_bench.verify.calibration import calibration_figures
    from pam_bench.verify.figures_004 import figure_rows, measure_004
    fig = calibration_figures(h_s=args.step)
    measured = measure_004()
    rows = figure_rows(measured)
    if args.json:
        print(dumps({**fig, 'figures_004': rows,
                     'readings_004': {k: v for k, v in measured.items()
                                      if k != 'isotonic_by_point'}}))
        return 0 if all(r['ok'] for r in rows) else 1
    print("004's figures on its full grids (quasi-static bench, the extraction's estimators; "
          'verify/figures_004.py says how each is read):')
    _figure_table(rows)
    print(f"  isometric gain as the secant F(6 V) / 6 V: "
          f"{measured['isometric_gain_secant_by_x']['0']:.1f} N/V at 0 mm, "
          f"{measured['isometric_gain_secant_by_x']['95']:.1f} N/V at 95 mm; isotonic minimum "
          f"at ({measured['isotonic_gain_min_u']:.2f} V, {measured['isotonic_gain_min_f']:.0f}"
          ' N)')
    print('\nThe dynamic bench on a coarse grid (0.5 V steps, 3 s dwell):')
    for k, v in fig.items():
        print(f'  {k:36s} {v:10.3f}')
    return 0 if all(r['ok'] for r in rows) else 1


def _calibrate_bags(args: argparse.Namespace) -> int:
    import yaml

    from pam_bench.bags.bagread import read_bags
    from pam_bench.cluster.layer import connect, map_on
    from pam_bench.fit.calibrate_bags import (
        bench_of_bags,
        bench_of_scene,
        calibrate_bags,
        check_observations,
        observations_from_bags,
        overlay_of,
    )
    base = bench_of_scene(args.scene)         # a bad scene: one line before anything
    if args.scene is None:
        base = bench_of_bags(args.bags[:1])   # the muscle and valve the bag was made with
    if args.each:
        return _calibrate_each(args)
    if args.out:
        check_output_file(args.out, VERB, args.overwrite, args.bags)
    data = read_bags(args.bags)
    obs = observations_from_bags(data)
    check_observations(obs)
    say = sys.stderr if args.json else sys.stdout      # with --json, stdout is the JSON only
    if obs.left_aside:
        print('left aside: ' + '; '.join(obs.left_aside), file=say)
    print(f'fitting the muscle and valve to {len(obs.readings)} readings and '
          f'{len(obs.records)} step records (the Jacobian on the cluster) ...', flush=True,
          file=say)
    with connect(**cluster_of(args)) as client:
        res = calibrate_bags(obs, *base, max_nfev=args.max_evaluations, replay=args.replay,
                             workers=map_on(client), start=args.start, starts=args.starts,
                             map_starts=map_on(client), law=args.law)
    if args.json:
        print(dumps({k: v for k, v in res.items() if k not in ('valve', 'muscle')}))
    else:
        _print_fit(res)
    verdict = Verdict(**res['verdict'])
    if args.out:
        overlay = overlay_of(res['valve'], res['muscle'], res['laws'])
        mark = '' if verdict.converged else '# NOT CONVERGED: ' + verdict.line() + '\n'
        write_output_file(args.out, VERB, f"{mark}# {' '.join(args.bags)}: muscle and valve "
                          'fitted to these recordings\n' + yaml.safe_dump(overlay,
                                                                            sort_keys=False))
        print(f'overlay written to {args.out} (pam-bench run SCENE --params {args.out})'
              + ('' if verdict.converged else ', marked not converged'), file=say)
    print(verdict.line(), file=say if verdict.converged else sys.stderr)
    return 0 if verdict.converged else NOT_CONVERGED


def _print_fit(res: Calibration) -> None:
    from pam_bench.fit.calibrate_bags import PATH_WIDTH_M
    print('started from (read off the data where it shows them):')
    for n, v in res['start'].items():
        print(f"  {n:28s} {v:12.6g}  {res['start_from'].get(n, 'the bench default')}")
    print('RMS error per protocol (N for forces, mm for contractions), before -> after, '
          'against the noise level:')
    tol = res['verdict']['tolerance']
    for k, after in res['rms_after'].items():
        print(f"  {k:14s} {res['rms_before'][k]:9.3f} -> {after:9.3f}  (noise level "
              f"{tol[k]:.3g})")
    if res.get('law_zoo'):
        print('the law zoo fitted statically to the isometric readings (RMS, N): ' + ', '.join(
            f'{k} {v:.3g}' for k, v in res['law_zoo'].items()))
    tried, best = res['starts']['tried'], res['starts']['at_best']
    print(f"fit: {res['evaluations']} evaluations in {res['fit_s']:.1f} s"
          + (f'; {best} of {tried} starts reached the best cost' if tried else ''))
    if res['left_out']:
        print(f"left out (friction loop wider than {PATH_WIDTH_M * 1e3:.0f} mm, the drive's "
              'transient places them): ' + ', '.join(
                  f'{k} {u:g} V {h:g} N' for k, u, h in dict.fromkeys(res['left_out'])))
    for n in res['names']:
        print(f"  {n:28s} {res['report'][n]}")
    corr = res['correlation']
    names = res['names'][:len(corr)]
    pairs = [(names[i], names[j], corr[i][j]) for i in range(len(names))
             for j in range(i + 1, len(names)) if abs(corr[i][j]) > 0.9]
    for a, b, c in pairs:
        print(f'  correlated: {a} and {b} ({c:+.2f})')


def _calibrate_each(args: argparse.Namespace) -> int:
    """One calibration per bag on the cluster; a broken bag is one line, the rest complete."""
    with contextlib.ExitStack() as stack:
        out = (stack.enter_context(staged_output(args.out, VERB, args.overwrite, args.bags))
               if args.out else None)
        failed, loose = _calibrate_jobs(args, out)
    print(f'{len(args.bags) - failed} of {len(args.bags)} bags calibrated, {loose} not '
          'converged' + (f'; overlays in {args.out}' if args.out else ''))
    return 1 if failed else NOT_CONVERGED if loose else 0


def _calibrate_jobs(args: argparse.Namespace, out: pathlib.Path | None) -> tuple[int, int]:
    """Run ``--each``'s jobs, print a line per bag, write its overlay into ``out``; returns
    how many failed and how many did not converge."""
    import yaml

    from pam_bench.cluster.layer import run_jobs
    from pam_bench.fit.calibrate_bags import calibrate_bag, overlay_of
    jobs = [(b, args.max_evaluations, args.replay, args.start, args.starts, args.law,
             args.scene) for b in args.bags]
    results = run_jobs(calibrate_bag, jobs, label='calibrate', **cluster_of(args))
    failed = loose = 0
    for r in results:
        bag = pathlib.Path(r.item[0])
        if not r.ok:
            failed += 1
            print(f'{bag.name}: error: {r.error}')
            continue
        res = r.value
        verdict = Verdict(**res['verdict'])
        loose += not verdict.converged
        print(f"{bag.name}: {verdict.line()} ({res['evaluations']} evaluations, "
              f'{r.seconds:.0f} s)')
        if out is not None:
            mark = '' if verdict.converged else '# NOT CONVERGED: ' + verdict.line() + '\n'
            overlay = overlay_of(res['valve'], res['muscle'], res['laws'])
            write_output_file(out / f'{bag.name}.yaml', VERB, f'{mark}# {bag}: fitted to this '
                              'bag\n' + yaml.safe_dump(overlay, sort_keys=False))
    return failed, loose


def _cmd_calibrate(args: argparse.Namespace) -> int:
    import yaml

    from pam_bench.fit.calibrate import calibrate_004
    if args.bags:
        return _calibrate_bags(args)
    if args.target != '004':
        raise UsageError(f'unknown target {args.target!r} (known: 004)')
    if args.out:
        check_output_file(args.out, VERB, args.overwrite)
    print("fitting the muscle to 004's figures (about a minute) ...", flush=True)
    res = calibrate_004(max_nfev=args.max_evaluations)
    overlay = {'parameters': {m: {'muscle': res['params']} for m in ('muscle_1', 'muscle_2')}}
    if args.out:
        write_output_file(args.out, VERB, "# --target 004: muscle parameters fitted to 004's "
                          'figures\n' + yaml.safe_dump(overlay, sort_keys=False))
    if args.json:
        print(dumps(res))
    else:
        _figure_table(res['figures'])
        print(f"fit: {res['evaluations']} evaluations in {res['fit_s']:.1f} s, cost "
              f"{res['cost']:.3g}")
        from pam_bench.fit.calibrate import fit_report
        for n, line in fit_report(res, 'not fixed by the figures').items():
            print(f'  {n:28s} {line}')
        if args.out:
            print(f'overlay written to {args.out} (pam-bench run SCENE --params {args.out})')
    return 0 if all(r['ok'] for r in res['figures']) else 1


def _cmd_extract(args: argparse.Namespace) -> int:
    from pam_bench.analysis.extract import extract
    if args.each:
        from pam_bench.analysis.batch import extract_each
        rows = extract_each(args.bags, args.out, cluster_of(args), args.overwrite)
        failed = [r for r in rows if r['error']]
        for r in failed:
            print(f"{r['bag']}: error: {r['error']}")
        print(f'{len(rows) - len(failed)} of {len(rows)} bags extracted; wrote '
              f'{args.out}/comparison.csv, comparison.md and drift.png')
        return 1 if failed else 0
    summary = extract(args.bags, args.out, overwrite=args.overwrite)
    t = summary['timing_s']
    print(f'wrote {args.out}/summary.json, report.md and CSV files '
          f'(read {t["read_and_static"]:.2f} s, {t["records"]} step fits '
          f'{t["identification"]:.2f} s)')
    return 0


def _cmd_truth(args: argparse.Namespace) -> int:
    from pam_bench.verify.truth import compare, truth_summary
    truth = truth_summary(args.scene, reference=not args.no_reference)
    if args.against:
        path = pathlib.Path(args.against)
        if path.is_dir():
            path = path / 'summary.json'
        try:
            summary = json.loads(path.read_text(encoding='utf-8'))
        except (OSError, ValueError) as exc:
            raise UsageError(f'cannot read {path}: {exc}') from None
        truth['comparison'] = compare(truth, summary)
    if args.json:
        print(dumps(truth))
        return 0
    for k in ('isometric', 'isotonic', 'isobaric'):
        if k in truth:
            print(k, json.dumps({a: b for a, b in truth[k].items() if a != 'series'}))
    if 'step_response' in truth:
        print(f"step_response: {len(truth['step_response']['fits'])} steps (use --json)")
    for name, rows in truth.get('comparison', {}).items():
        print(f'{name}: {json.dumps(rows)[:2000]}')
    return 0
