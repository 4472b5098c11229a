"""pam-bench: command-line verbs over the bench (run a scene, calibration, rates)."""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import signal
import sys

from pam_bench.models.errors import ModelError

__all__ = ['main']


def _replayed(args: argparse.Namespace) -> tuple[object, dict | None] | None:
    """The scene and resolved parameters a bag recorded (``run --replay BAG``)."""
    import tempfile

    from pam_bench.analysis.baginfo import run_of_bag
    from pam_bench.analysis.bagread import BagError
    from pam_bench.config.scene import load_scene
    try:
        run = run_of_bag(args.replay)
    except BagError as exc:
        print(f'error: cannot replay: {exc}', file=sys.stderr)
        return None
    with tempfile.TemporaryDirectory(prefix='pam_bench_replay_') as tmp:
        path = pathlib.Path(tmp) / f'{run["scene"]}.yaml'
        path.write_text(run['scene_text'], encoding='utf-8')
        scene = load_scene(str(path))
    args.seed = int(run['seed'])
    layout = run.get('layout', '')
    if layout == 'one process':
        args.one_process = True
    elif layout == 'wall clock':
        args.wallclock = True
    print(f'replaying {args.replay}: scene {run["scene"]}, seed {args.seed}, {layout}, '
          f'recorded at commit {run["commit"][:12]}' + (' (dirty)' if run.get('dirty') else ''))
    return scene, run.get('parameters')


def _cmd_run(args: argparse.Namespace) -> int:
    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    parameters = None
    if args.replay:
        if args.scene or not args.out:
            print('error: --replay BAG takes no scene and needs --out', file=sys.stderr)
            return 2
        replayed = _replayed(args)
        if replayed is None:
            return 2
        scene, parameters = replayed
    elif not args.scene:
        print('error: name a scene (or --replay BAG)', file=sys.stderr)
        return 2
    else:
        scene = load_scene(args.scene)
    if args.params:
        from pam_bench.config.scene import apply_overlay
        apply_overlay(scene, args.params)
    out = pathlib.Path(args.out or f'bags/{scene.name}')
    if args.resume and pathlib.Path(args.resume).resolve() == out.resolve():
        print('error: --resume needs a new --out (the old bag is kept)', file=sys.stderr)
        return 2
    if out.exists():
        if not args.overwrite and args.out:
            print(f'error: {out} exists (use --overwrite)', file=sys.stderr)
            return 2
        shutil.rmtree(out)
    if args.resume:
        from pam_bench.analysis.bagread import BagError
        from pam_bench.bringup.resume import resume_reading
        try:
            start, total = resume_reading(scene, args.resume)
        except BagError as exc:
            print(f'error: cannot resume from {args.resume}: {exc}', file=sys.stderr)
            return 2
        if start >= total:
            print(f'{args.resume} holds every reading of {scene.protocol}: nothing to resume')
            return 0
        scene.parameters.setdefault('sequencer', {})['resume_from_reading'] = start
        print(f'resuming {scene.protocol} at reading {start} of {total} (the first one '
              f'{args.resume} lacks)')
    print(f'scene {scene.name}: {scene.description}\n  exchange step {scene.exchange_step_s} s, '
          f'nodes {", ".join(scene.nodes)}, bag {out}', flush=True)
    if args.wallclock and (args.one_process or args.realtime or args.resume):
        print('error: --wallclock runs the devices in the emulator on the wall clock: drop '
              '--one-process, --realtime and --resume', file=sys.stderr)
        return 2
    res = run_scene(scene, str(out), seed=args.seed, realtime=args.realtime,
                    one_process=args.one_process, wallclock=args.wallclock,
                    device_processes=args.device_processes, parameters=parameters,
                    netns=tuple(args.netns.split(':', 1)) if args.netns else None)
    if res.code == 130:
        print(f'interrupted: nodes stopped, bag closed in {out}', file=sys.stderr)
        return 130
    if res.code != 0:
        print(f'error: scene {scene.name} failed (exit code {res.code})', file=sys.stderr)
        return res.code
    if args.wallclock:
        _print_wall_stats(res.stats)
        print(f'done: {res.wall_s:.1f} s on the wall clock; bag in {out}')
        return 0
    print(f'done: {res.steps} exchange steps, {res.sim_s:.2f} s sim in {res.wall_s:.2f} s wall '
          f'({res.rate:.0f} steps/s, x{res.sim_s / res.wall_s if res.wall_s else 0:.1f} real '
          f'time); bag in {out}')
    return 0


def _print_wall_stats(stats: dict) -> None:
    """Period statistics per ticking node and the recorder's delivery table."""
    from pam_bench.analysis.delivery import delivery_table, format_delivery
    for name, st in stats.items():
        per = st.get('periods')
        if per:
            print(f'{name:14s} period mean {per["mean_s"] * 1e3:.3f} ms, p50 '
                  f'{per["p50_s"] * 1e3:.3f}, p99 {per["p99_s"] * 1e3:.3f}, max '
                  f'{per["max_s"] * 1e3:.3f} ms (at {per["max_at_s"]:.1f} s), late '
                  f'{per["late_share"] * 100:.2f} %')
    if 'recorder' in stats:
        print(format_delivery(delivery_table(
            [v for k, v in stats.items() if k != 'recorder'], stats['recorder'])))


def _cmd_record(args: argparse.Namespace) -> int:
    from pam_bench.nodes.recorder import record
    if not args.topics and not args.all:
        print('error: name the topics to record or give --all', file=sys.stderr)
        return 2
    out = pathlib.Path(args.out)
    if out.exists():
        print(f'error: {out} exists', file=sys.stderr)
        return 2
    return record(str(out), args.topics, args.all)


def _cmd_bag_repair(args: argparse.Namespace) -> int:
    from pam_bench.analysis.bag_repair import repair_bag
    from pam_bench.analysis.bagread import BagError
    try:
        rep = repair_bag(args.bag)
    except BagError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    if not rep.needed:
        print(f'{args.bag} is a valid bag: nothing to repair')
        return 0
    print(f'{args.bag} rebuilt from its complete records ({rep.lost_bytes} bytes of a torn '
          f'chunk unreadable); the old folder is {rep.broken_copy}')
    for topic, n in sorted(rep.kept.items()):
        print(f'  {topic:34s} {n:8d} messages kept')
    return 0


def _cmd_info(args: argparse.Namespace) -> int:
    from pam_bench.analysis.baginfo import bag_info
    from pam_bench.analysis.bagread import BagError
    try:
        info = bag_info(args.bag)
    except BagError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(info, indent=2, default=str))
        return 0
    run, end = info['run'] or {}, info['end'] or {}
    if run:
        v = run.get('versions', {})
        print(f"scene     {run['scene']} (seed {run['seed']}, {run.get('layout', '?')})\n"
              f"commit    {run['commit']}" + (' (dirty)' if run.get('dirty') else '') + '\n'
              f"made      {run['start']} on {run['host']}\n"
              f"command   {' '.join(run.get('command_line', []))}\n"
              f"versions  pam_bench {v.get('pam_bench')}, rclpy {v.get('rclpy')}, rosbags "
              f"{v.get('rosbags')}, numpy {v.get('numpy')}\n"
              f"nodes     {', '.join(k for k in run.get('parameters', {}) if k != 'sim_clock')}")
        if args.parameters:
            from pam_bench.bringup.runner import flatten
            for node, p in run.get('parameters', {}).items():
                flat = flatten(p.get('ros__parameters', {}))
                shown = {k: v for k, v in flat.items() if k not in ('run_yaml', 'end_file')}
                print(f'  {node}: ' + ', '.join(f'{k}={v}' for k, v in sorted(shown.items())))
    else:
        print('no run description in this bag (an older pam_bench or another recorder)')
    if end:
        print(f"ended     {end.get('state')}" + (f": {end['reason']}" if end.get('reason')
                                                 else '') + f" at {end.get('end')}")
    print(f"duration  {info['duration_s']:.3f} s of log time")
    for topic, t in sorted(info['topics'].items()):
        print(f"  {topic:34s} {t['count']:9d}  {t['type']}")
    return 0


def _cmd_diff(args: argparse.Namespace) -> int:
    from pam_bench.analysis.bagdiff import diff_bags
    from pam_bench.analysis.bagread import BagError
    try:
        d = diff_bags(args.bag_a, args.bag_b)
    except BagError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(d, indent=2))
    same = True
    for name, row in d.items():
        worst = {k: v for k, v in row.items() if k.startswith('max_')}
        same &= row['only_a'] == row['only_b'] == 0 and all(v == 0 for v in worst.values())
        if not args.json:
            print(f"{name:24s} {row['matched']:6d} matched, {row['only_a']} only in A, "
                  f"{row['only_b']} only in B; largest: "
                  + ', '.join(f'{k[4:]} {v:.6g}' for k, v in worst.items()))
    print('identical readings' if same else 'the bags differ')
    return 0 if same else 1


def _cmd_size(args: argparse.Namespace) -> int:
    import dataclasses

    from pam_bench.models.laws.straight_fibre import size
    if args.inverse:
        return _size_inverse(args)
    missing = [n for n in ('diameter_mm', 'length_mm') if getattr(args, n) is None]
    if missing:
        print(f'error: forward sizing needs --{missing[0].replace("_", "-")} (or --inverse '
              '--contraction-mm C)', file=sys.stderr)
        return 2
    try:
        r = size(args.diameter_mm * 1e-3, args.length_mm * 1e-3, args.segments,
                 args.wall_mm * 1e-3, args.force_n, args.pressure_mpa * 1e6)
    except ModelError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
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
        print('error: --inverse needs --contraction-mm', file=sys.stderr)
        return 2
    try:
        found = designs_for(args.force_n, args.contraction_mm * 1e-3, args.pressure_mpa * 1e6,
                            args.segments, args.wall_mm * 1e-3)
    except ModelError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
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


def _cmd_emulate(args: argparse.Namespace) -> int:
    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    res = run_scene(load_scene(args.scene), '', seed=args.seed, wallclock=True,
                    devices_only=True)
    return 0 if res.code in (0, 130) else res.code


def _cmd_check_drivers(args: argparse.Namespace) -> int:
    from pam_bench.config.scene import load_scene
    from pam_bench.nodes.driver_probe import probe_drivers
    nodes = load_scene(args.scene).nodes
    controllers = [n for n in ('sequencer', 'torque_servo') if n in nodes]
    if not controllers:
        print(f'error: scene {args.scene} has no sequencer or torque servo: nothing reads '
              'drivers', file=sys.stderr)
        return 2
    verdicts = probe_drivers(controllers, args.duration)
    print(f'{"topic":26s} {"expected":44s} {"seen":36s} result')
    for v in verdicts:
        print(f'{v.topic:26s} {v.expected:44s} {v.seen:36s} '
              + ('pass' if v.ok else 'FAIL') + (f': {v.reason}' if v.reason else ''))
    failed = [v for v in verdicts if not v.ok]
    print(f'{len(verdicts) - len(failed)} of {len(verdicts)} pass')
    return 1 if failed else 0


def _figure_table(rows: list[dict]) -> None:
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
        print(json.dumps({**fig, 'figures_004': rows,
                          'readings_004': {k: v for k, v in measured.items()
                                           if k != 'isotonic_by_point'}}, indent=2))
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

    from pam_bench.analysis.bagread import BagError, read_bags
    from pam_bench.verify.calibrate_bags import (
        PATH_WIDTH_M,
        calibrate_bags,
        observations_from_bags,
        overlay_of,
    )
    try:
        data = read_bags(args.bags)
    except BagError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    obs = observations_from_bags(data)
    print(f'fitting the muscle and valve to {len(obs.readings)} readings and '
          f'{len(obs.records)} step records ...', flush=True)
    res = calibrate_bags(obs, max_nfev=args.max_evaluations, replay=args.replay)
    if args.json:
        print(json.dumps({k: v for k, v in res.items() if k not in ('valve', 'muscle')},
                         indent=2))
    else:
        print('RMS error per protocol (N for forces, mm for contractions), before -> after:')
        for k, after in res['rms_after'].items():
            print(f"  {k:14s} {res['rms_before'][k]:9.3f} -> {after:9.3f}")
        print(f"fit: {res['evaluations']} evaluations in {res['fit_s']:.1f} s")
        if res['left_out']:
            print(f"left out (friction loop wider than {PATH_WIDTH_M * 1e3:.0f} mm, the drive's "
                  'transient places them): ' + ', '.join(
                      f'{k} {u:g} V {h:g} N' for k, u, h in dict.fromkeys(res['left_out'])))
        for n in res['names']:
            flag = '  (not fixed by these recordings)' if n in res['flags'] else ''
            print(f"  {n:28s} {res['values'][n]:12.5g} +- {res['stderr'][n]:.2g}{flag}")
        corr, names = res['correlation'], res['names']
        pairs = [(names[i], names[j], corr[i][j]) for i in range(len(names))
                 for j in range(i + 1, len(names)) if abs(corr[i][j]) > 0.9]
        for a, b, c in pairs:
            print(f'  correlated: {a} and {b} ({c:+.2f})')
    if args.out:
        overlay = overlay_of(res['valve'], res['muscle'])
        pathlib.Path(args.out).write_text(
            f"# pam-bench calibrate {' '.join(args.bags)}: muscle and valve fitted to these "
            'recordings\n' + yaml.safe_dump(overlay, sort_keys=False), encoding='utf-8')
        print(f'overlay written to {args.out} (pam-bench run SCENE --params {args.out})')
    return 0


def _cmd_calibrate(args: argparse.Namespace) -> int:
    import yaml

    from pam_bench.verify.calibrate import calibrate_004
    if args.bags:
        return _calibrate_bags(args)
    if args.target != '004':
        print(f'error: unknown target {args.target!r} (known: 004)', file=sys.stderr)
        return 2
    print("fitting the muscle to 004's figures (about a minute) ...", flush=True)
    res = calibrate_004(max_nfev=args.max_evaluations)
    overlay = {'parameters': {m: {'muscle': res['params']} for m in ('muscle_1', 'muscle_2')}}
    if args.out:
        pathlib.Path(args.out).write_text(
            "# pam-bench calibrate --target 004: muscle parameters fitted to 004's figures\n"
            + yaml.safe_dump(overlay, sort_keys=False), encoding='utf-8')
    if args.json:
        print(json.dumps(res, indent=2))
    else:
        _figure_table(res['figures'])
        print(f"fit: {res['evaluations']} evaluations in {res['fit_s']:.1f} s, cost "
              f"{res['cost']:.3g}")
        for n in res['names']:
            flag = '  (not fixed by the figures)' if n in res['flags'] else ''
            print(f"  {n:28s} {res['values'][n]:12.5g} +- {res['stderr'][n]:.2g}{flag}")
        if args.out:
            print(f'overlay written to {args.out} (pam-bench run SCENE --params {args.out})')
    return 0 if all(r['ok'] for r in res['figures']) else 1


def _cmd_pingpong(args: argparse.Namespace) -> int:
    from pam_bench.benchmarks.pingpong import pingpong_rate
    rate = pingpong_rate(args.count)
    print(json.dumps({'pingpong_round_trips_per_s': rate}) if args.json
          else f'rclpy ping-pong between two processes: {rate:.0f} round trips/s')
    return 0


def _raise_interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def _cmd_extract(args: argparse.Namespace) -> int:
    from pam_bench.analysis.bagread import BagError
    from pam_bench.analysis.extract import ExtractError, extract
    try:
        summary = extract(args.bags, args.out)
    except (BagError, ExtractError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
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
            print(f'error: cannot read {path}: {exc}', file=sys.stderr)
            return 2
        truth['comparison'] = compare(truth, summary)
    if args.json:
        print(json.dumps(truth, indent=2))
        return 0
    for k in ('isometric', 'isotonic', 'isobaric'):
        if k in truth:
            print(k, json.dumps({a: b for a, b in truth[k].items() if a != 'series'}))
    if 'step_response' in truth:
        print(f"step_response: {len(truth['step_response']['fits'])} steps (use --json)")
    for name, rows in truth.get('comparison', {}).items():
        print(f'{name}: {json.dumps(rows)[:2000]}')
    return 0


def _cmd_servo_compare(args: argparse.Namespace) -> int:
    from pam_bench.benchmarks.servo_compare import compare_servo
    out = pathlib.Path(args.out)
    jobs = args.jobs or (os.cpu_count() or 1 if args.engine == 'numpy' or args.one_process
                         else 1)
    rows = compare_servo(out, args.engine, args.scene or None, args.duration, args.one_process,
                         jobs)
    print(f"{'scene':26s} {'controller':20s} {'RMS':>8s} {'max':>8s} {'at reversal':>12s}")
    for r in rows:
        print(f"{r['scene']:26s} {r['controller']:20s} {r['rms_error']:8.3f} "
              f"{r['max_error']:8.3f} {r['error_at_reversal']:12.3f} {r['unit']}")
    forward = [r for r in rows if 'forward_model_rms_N' in r]
    if forward:
        print("004's forward model (Eq. 4) driven by each run's voltage, RMS against the "
              'measured force:')
        for r in forward:
            print(f"  {r['scene']:24s} {r['controller']:20s} {r['forward_model_rms_N']:8.2f} N")
    print(f'wrote {out / "metrics.json"} and one plot per scene')
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    from pam_bench.benchmarks.suite import render_report, run_benchmarks
    root = pathlib.Path(args.root)
    if args.render:
        print(f'wrote {render_report(root)} from {root / "bench.json"}')
        return 0
    only = [s for part in args.only or [] for s in part.split(',') if s]
    try:
        run_benchmarks(args.quick, root, args.scene or None, only or None)
    except ValueError as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    print(f'wrote {root / "BENCHMARKS.md"} and {root / "bench.json"}')
    return 0


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pam-bench``."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    # small matrices only: BLAS thread pools just spin against the node processes
    for var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
        os.environ.setdefault(var, '1')
    # Ctrl-C and SIGTERM end a run: nodes stopped, bag closed, no orphans. Installed whatever
    # was inherited: a background job of a non-interactive shell starts with SIGINT ignored.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _raise_interrupt)
    ap = argparse.ArgumentParser(prog='pam-bench', description=__doc__)
    sub = ap.add_subparsers(dest='cmd', required=True)
    p = sub.add_parser('run', help='run a scene and record a bag')
    p.add_argument('scene', nargs='?', help='scene name in config/scenes or a path to a scene '
                   'file')
    p.add_argument('--replay', metavar='BAG', help="run a bag's own scene again with its "
                   'recorded parameters, seed and layout (into --out)')
    p.add_argument('--out', help='bag directory (default bags/SCENE, replaced)')
    p.add_argument('--overwrite', action='store_true', help='replace --out if it exists')
    p.add_argument('--params', metavar='FILE', help='parameter overlay (pam-bench calibrate '
                   "--out): over config/bench.yaml, under the scene's own parameters")
    p.add_argument('--seed', type=int, default=0, help='seed of the sensor noise')
    p.add_argument('--realtime', action='store_true', help='pace sim time to the wall clock')
    p.add_argument('--one-process', action='store_true', help='compose all nodes in one process')
    p.add_argument('--resume', metavar='BAG', help='bag of an interrupted run of this scene: '
                   'start at the first reading it lacks (into a new --out)')
    p.add_argument('--wallclock', action='store_true', help='run on the wall clock as on a '
                   'real bench: devices free-running in one emulator process, controllers and '
                   'recorder in their own')
    p.add_argument('--netns', metavar='DEVICES_NS:OTHER_NS', help='run the simulated devices '
                   'in one network namespace and the other nodes in another, as on two hosts '
                   '(lock-step, separate processes; README, "Two hosts")')
    p.add_argument('--device-processes', action='store_true', help='with --wallclock: each '
                   'device in its own process instead of the emulator')
    p.set_defaults(func=_cmd_run)
    p = sub.add_parser('record', help='record topics of a running graph on the wall clock '
                       '(like ros2 bag record), until Ctrl-C')
    p.add_argument('topics', nargs='*', help='topic names (types are discovered)')
    p.add_argument('--all', action='store_true', help='every topic that appears')
    p.add_argument('--out', required=True, help='bag directory to create')
    p.set_defaults(func=_cmd_record)
    p = sub.add_parser('bag-repair', help='rebuild a bag whose recorder was killed')
    p.add_argument('bag', help='rosbag2 folder')
    p.set_defaults(func=_cmd_bag_repair)
    p = sub.add_parser('info', help='how a bag was made and what it holds')
    p.add_argument('bag')
    p.add_argument('--parameters', action='store_true', help="print every node's resolved "
                   'parameters too')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_info)
    p = sub.add_parser('diff', help='two bags compared reading by reading (exit 1: differ)')
    p.add_argument('bag_a')
    p.add_argument('bag_b')
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_diff)
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
    p = sub.add_parser('emulate', help="run only a scene's simulated devices on the wall "
                       'clock, until Ctrl-C (a bench for your own controllers)')
    p.add_argument('scene', nargs='?', default='demo')
    p.add_argument('--seed', type=int, default=0, help='seed of the sensor noise')
    p.set_defaults(func=_cmd_emulate)
    p = sub.add_parser('check-drivers', help='join a running bench and check that its drivers '
                       'meet the contract (docs/drivers.md)')
    p.add_argument('scene', nargs='?', default='demo', help='scene whose controllers will read '
                   'the drivers (default demo: the sequencer)')
    p.add_argument('--duration', type=float, default=3.0, help='listening time, s')
    p.set_defaults(func=_cmd_check_drivers)
    p = sub.add_parser('calibration', help='figures the simulated bench implies')
    p.add_argument('--json', action='store_true')
    p.add_argument('--step', type=float, default=0.01, help='exchange step, s')
    p.set_defaults(func=_cmd_calibration)
    p = sub.add_parser('calibrate', help="fit the bench's muscle (and valve) to recorded bags, "
                       "or to 004's figures (--target 004)")
    p.add_argument('bags', nargs='*', help='rosbag2 folders of a campaign (static readings '
                   'and step records)')
    p.add_argument('--target', default='004', help="without bags: what to fit to (004: the "
                   "paper's figures)")
    p.add_argument('--out', help='write the fitted parameters as an overlay (run --params)')
    p.add_argument('--max-evaluations', type=int, default=60,
                   help='largest number of residual evaluations')
    p.add_argument('--replay', choices=('stepped', 'static'), default='stepped',
                   help="bags: replay the readings on the time-stepped bench with 004's drive "
                   '(stepped) or on the quasi-static bench with an ideal drive (static, about '
                   "four times faster; for a drive that is not 004's)")
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_calibrate)
    p = sub.add_parser('pingpong', help='rclpy round-trip rate between two processes')
    p.add_argument('--count', type=int, default=2000)
    p.add_argument('--json', action='store_true')
    p.set_defaults(func=_cmd_pingpong)
    p = sub.add_parser('extract', help='bags -> characteristics, gains, identified model')
    p.add_argument('bags', nargs='+', help='rosbag2 directories')
    p.add_argument('--out', required=True, help='output folder (replaced when complete)')
    p.set_defaults(func=_cmd_extract)
    p = sub.add_parser('truth', help="what the scene's parameters imply (summary.json keys)")
    p.add_argument('scene', help='scene name or scene file')
    p.add_argument('--json', action='store_true', help='print the whole JSON')
    p.add_argument('--against', help='an extraction folder or summary.json to compare with')
    p.add_argument('--no-reference', action='store_true',
                   help='skip the noise-free simulated step responses (faster)')
    p.set_defaults(func=_cmd_truth)
    p = sub.add_parser('servo-compare', help='every servo scene x controller -> metrics.json')
    p.add_argument('--engine', choices=['numpy', 'ros'], default='ros',
                   help='ros: separate-process nodes (minutes); numpy: same models in one '
                   'process (seconds)')
    p.add_argument('--out', default='reports/servo', help='output folder')
    p.add_argument('--scene', action='append', help='servo scene (repeatable; default all)')
    p.add_argument('--duration', type=float, help='sim time per run, s (default: the scene)')
    p.add_argument('--one-process', action='store_true',
                   help='with --engine ros: compose the nodes in one process (same bags, faster)')
    p.add_argument('--jobs', type=int, default=0,
                   help='runs at once, each in a worker process on its own ROS domain (default: '
                   'one per CPU for numpy and --one-process, else 1)')
    p.set_defaults(func=_cmd_servo_compare)
    p = sub.add_parser('bench', help='benchmarks -> BENCHMARKS.md and bench.json')
    p.add_argument('--quick', action='store_true', help='a few minutes: quick grids and scenes')
    p.add_argument('--root', default='.', help='where to write the report (default: here)')
    p.add_argument('--scene', action='append', help='scene to time (repeatable)')
    p.add_argument('--only', action='append', metavar='STUDY[,STUDY]',
                   help='run only these studies (calibration, lockstep, layouts, profile, '
                   'exchange_step, record_exchange, scenes, models, wallclock, faults, '
                   'straight_fibre, calibrate, calibrate_nodes) and keep the other figures of '
                   'bench.json, each with the commit it was measured at')
    p.add_argument('--render', action='store_true', help='only render BENCHMARKS.md again from '
                   'bench.json and docs/long_runs.md (no measurement)')
    p.set_defaults(func=_cmd_bench)
    args = ap.parse_args(argv)
    try:
        return args.func(args)
    except (ModelError, FileNotFoundError, FileExistsError) as exc:
        print(f'error: {exc}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print('interrupted: nodes stopped, bag closed', file=sys.stderr)
        return 130
    except BrokenPipeError:            # `pam-bench ... | head`: the reader has gone, no traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


if __name__ == '__main__':
    sys.exit(main())
