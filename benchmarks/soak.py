"""Soak: a long wall-clock run of ``isometric`` watched from outside, extrapolated to 6.1 h.

``pam-bench run isometric --wallclock`` runs as a lab runs it (its own process group, the
recorder at its defaults: zstd chunks, files under 1 GB) for ``SOAK_S`` (``--quick``:
``QUICK_SOAK_S``) and is then stopped with SIGINT, as Ctrl-C stops it. Every ``SAMPLE_S``
the study reads
``/proc`` for each process of the run: resident memory (RSS) and CPU time, and the bag's
bytes. From the samples: the RSS slope per process (least squares over the samples after the
first minute, MB/h), the CPU share, the bag's growth (GB/h, compressed as written, and
uncompressed from the MCAP chunk index). From the bag and its ``wall_stats.json``: the
device topics' rate over every 10 s window of their header stamps, the recorder's lag
(receive time - header stamp), messages lost, late periods and dropped ticks. Each figure is
extrapolated linearly to ``CAMPAIGN_H``.
"""

from __future__ import annotations

import json
import os
import pathlib
import signal
import subprocess
import sys
import time
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table

__all__ = ['STUDY', 'measure_soak', 'soak_section', 'soak_results', 'process_sample',
           'CAMPAIGN_H', 'SOAK_S', 'SAMPLE_S']

CAMPAIGN_H = 6.1
"""Length of 004's characterisation campaign, h: the ``campaign`` scene's 21 926 s of bench
time (BENCHMARKS.md, "Both layouts against the ping-pong floor")."""
SOAK_S = 1200.0
"""Length of the soak run, s (``--quick``: ``QUICK_SOAK_S``)."""
QUICK_SOAK_S = 30.0
SAMPLE_S = 10.0
"""Sampling period of the processes, s."""
WINDOW_S = 10.0
"""Window of the device-rate check, s."""
DEVICE_TOPICS = ('/load_cell_1/force', '/valve_1/pressure', '/encoder/joint_state',
                 '/loading_servo/state')
SETTLE_S = 60.0
"""Start-up excluded from the RSS slope, s."""


def _children(pid: int) -> list[int]:
    """``pid`` and every process below it."""
    parent: dict[int, int] = {}
    for d in pathlib.Path('/proc').iterdir():
        if d.name.isdigit():
            try:
                fields = (d / 'stat').read_text().rsplit(')', 1)[1].split()
                parent[int(d.name)] = int(fields[1])
            except (OSError, IndexError, ValueError):
                continue
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += [c for c, pp in parent.items() if pp == p]
    return out


def _name(pid: int) -> str:
    """A process's role: the node module it runs, the emulator, or the runner."""
    try:
        argv = (pathlib.Path('/proc') / str(pid) / 'cmdline').read_bytes().split(b'\0')
    except OSError:
        return str(pid)
    args = [a.decode(errors='replace') for a in argv if a]
    for a in args:
        if a.startswith('pam_bench.nodes.') or a.startswith('pam_bench.bringup.'):
            return a.rsplit('.', 1)[1]
    return 'runner' if 'pam_bench.cli' in args else (pathlib.Path(args[0]).name if args else '?')


def process_sample(pid: int) -> dict[str, tuple[float, float]]:
    """Role -> (RSS in bytes, CPU seconds) of ``pid`` and its descendants, from ``/proc``."""
    page = os.sysconf('SC_PAGE_SIZE')
    tick = os.sysconf('SC_CLK_TCK')
    out: dict[str, tuple[float, float]] = {}
    for p in _children(pid):
        try:
            rss = int((pathlib.Path('/proc') / str(p) / 'statm').read_text().split()[1]) * page
            f = (pathlib.Path('/proc') / str(p) / 'stat').read_text().rsplit(')', 1)[1].split()
            cpu = (int(f[11]) + int(f[12])) / tick
        except (OSError, IndexError, ValueError):
            continue
        name = _name(p)
        while name in out:
            name += "'"
        out[name] = (float(rss), cpu)
    return out


def _bag_bytes(bag: pathlib.Path) -> int:
    return sum(f.stat().st_size for f in bag.rglob('*.mcap')) if bag.exists() else 0


def _slope_per_h(t_s: np.ndarray, y: np.ndarray) -> float:
    keep = t_s >= min(SETTLE_S, float(t_s[-1]) / 2)
    if keep.sum() < 3:
        return float('nan')
    return float(np.polyfit(t_s[keep], y[keep], 1)[0] * 3600.0)


def _rss_at_campaign_mb(p: dict[str, Any], run_h: float) -> float:
    """A process's RSS (MB) at the campaign's end: its last sample plus its growth, if any,
    over the ``CAMPAIGN_H - run_h`` hours the run did not last."""
    return p['rss_mb_last'] + max(p['rss_slope_mb_h'], 0.0) * (CAMPAIGN_H - run_h)


def _bag_figures(bag: pathlib.Path) -> dict[str, Any]:
    """Device rates over 10 s windows of header stamps, the recorder's lag, uncompressed
    bytes."""
    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader

    from pam_bench.runtime.messages import stamp_of_cdr
    stamps: dict[str, list[int]] = {t: [] for t in DEVICE_TOPICS}
    lag: list[int] = []
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if c.topic in stamps]
        for conn, t, raw in reader.messages(connections=conns):
            s = stamp_of_cdr(bytes(raw))
            stamps[conn.topic].append(s)
            if conn.topic == DEVICE_TOPICS[0]:
                lag.append(t - s)
    rates: dict[str, dict[str, float]] = {}
    for topic, st in stamps.items():
        if len(st) < 2:
            continue
        a = np.sort(np.asarray(st, dtype=np.int64))
        t0 = a[0] + round(2e9)           # past start-up
        edges = np.arange(t0, a[-1] - round(WINDOW_S * 1e9), round(WINDOW_S * 1e9))
        if edges.size < 2:
            continue
        counts = np.diff(np.searchsorted(a, edges)) / WINDOW_S
        rates[topic] = {'min_hz': float(counts.min()), 'max_hz': float(counts.max()),
                        'mean_hz': float(counts.mean()), 'windows': int(counts.size)}
    raw_bytes = 0
    for f in sorted(bag.glob('*.mcap')):
        with open(f, 'rb') as fh:
            summary = make_reader(fh).get_summary()
        if summary is not None:
            raw_bytes += sum(c.uncompressed_size for c in summary.chunk_indexes)
    lag_a = np.asarray(lag, dtype=float) * 1e-9
    return {'rates': rates, 'uncompressed_chunk_bytes': raw_bytes,
            'lag_s': {'p50': float(np.percentile(lag_a, 50)),
                      'p99': float(np.percentile(lag_a, 99)),
                      'max': float(lag_a.max())} if lag_a.size else {},
            'files': len(list(bag.glob('*.mcap')))}


def measure_soak(out: pathlib.Path, quick: bool, duration_s: float | None = None,
                 scene: str = 'isometric') -> dict[str, Any]:
    """Run the soak (module docstring); ``duration_s`` overrides its length."""
    from pam_bench.analysis.delivery import delivery_table
    from pam_bench.bringup.common import ros_env
    from pam_bench.bringup.wallclock import STATS_FILE
    length = duration_s or (QUICK_SOAK_S if quick else SOAK_S)
    bag = out / 'soak_bag'
    log = out / 'soak_run.log'
    out.mkdir(parents=True, exist_ok=True)
    print(f'  soak: {scene} on the wall clock for {length:.0f} s ...', flush=True)
    with open(log, 'w', encoding='utf-8') as fh:
        proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'run', scene,
                                 '--wallclock', '--out', str(bag), '--overwrite'],
                                env=ros_env(None), stdout=fh, stderr=subprocess.STDOUT,
                                start_new_session=True)
        samples: list[dict[str, Any]] = []
        t0 = time.monotonic()
        try:
            while proc.poll() is None:
                now = time.monotonic() - t0
                samples.append({'t_s': now, 'procs': process_sample(proc.pid),
                                'bag_bytes': _bag_bytes(bag)})
                if now >= length:
                    break
                time.sleep(max(0.0, t0 + len(samples) * SAMPLE_S - time.monotonic()))
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
            try:
                code = proc.wait(timeout=120)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                code = proc.wait()
    stats = json.loads((bag / STATS_FILE).read_text()) if (bag / STATS_FILE).exists() else {}
    t = np.array([s['t_s'] for s in samples])
    names = sorted({n for s in samples for n in s['procs']})
    procs = {}
    for n in names:
        pts = [(s['t_s'], *s['procs'][n]) for s in samples if n in s['procs']]
        if len(pts) < 2:
            continue
        a = np.array(pts)
        procs[n] = {'rss_mb_first': a[0, 1] / 1e6, 'rss_mb_last': a[-1, 1] / 1e6,
                    'rss_slope_mb_h': _slope_per_h(a[:, 0], a[:, 1] / 1e6),
                    'cpu_share': float((a[-1, 2] - a[0, 2]) / max(a[-1, 0] - a[0, 0], 1e-9))}
    bag_b = np.array([s['bag_bytes'] for s in samples], dtype=float)
    figures = _bag_figures(bag) if (bag / 'metadata.yaml').exists() else {}
    span_h = float(t[-1] - t[0]) / 3600.0 if t.size > 1 else float('nan')
    rows = delivery_table({k: v for k, v in stats.items() if k != 'recorder'},
                          stats['recorder']) if 'recorder' in stats else []
    periods = {k: v['periods'] for k, v in stats.items() if v.get('periods')}
    dropped = {k: v.get('dropped_ticks', 0) for k, v in stats.items() if v.get('periods')}
    final = bag_b[-1] if bag_b.size else 0.0
    gb_h = _slope_per_h(t, bag_b / 1e9) if t.size > 2 else float('nan')
    raw = figures.get('uncompressed_chunk_bytes', 0)
    ratio = raw / final if final else float('nan')
    ram_6h = sum(_rss_at_campaign_mb(p, span_h) for p in procs.values()) / 1e3
    return {'scene': scene, 'duration_s': float(length), 'code': code,
            'samples': len(samples), 'processes': procs,
            'lost': int(sum(r.lost or 0 for r in rows)),
            'written': int(sum(r.written for r in rows)),
            'periods': periods, 'dropped_ticks': dropped, **figures,
            'bag_bytes': int(final), 'bag_gb_h': gb_h, 'bag_gb_h_uncompressed': gb_h * ratio,
            'extrapolated': {'hours': CAMPAIGN_H, 'ram_gb': ram_6h,
                             'disk_gb': gb_h * CAMPAIGN_H,
                             'disk_gb_uncompressed': gb_h * ratio * CAMPAIGN_H}}


def soak_section(r: dict[str, Any], plots: pathlib.Path) -> list[str]:
    """The tables of the section."""
    s = r['soak']
    e = s['extrapolated']
    lines = [f"`{s['scene']}` on the wall clock for {s['duration_s'] / 60:.0f} min "
             f"(exit code {s['code']}: 130 is the SIGINT that ends it), {s['samples']} samples; "
             f"extrapolated to {e['hours']} h.", '']
    lines += table(['process', 'RSS first MB', 'RSS last MB', 'RSS slope MB/h', 'CPU share',
                    f"RSS at {e['hours']} h MB"],
                   [(n, f"{p['rss_mb_first']:.1f}", f"{p['rss_mb_last']:.1f}",
                     f"{p['rss_slope_mb_h']:+.2f}", f"{p['cpu_share'] * 100:.1f} %",
                     f"{_rss_at_campaign_mb(p, s['duration_s'] / 3600.0):.0f}")
                    for n, p in sorted(s['processes'].items())])
    lines += ['', 'Device topics, rate over every 10 s window of header stamps:', '']
    lines += table(['topic', 'windows', 'min Hz', 'mean Hz', 'max Hz'],
                   [(t, v['windows'], f"{v['min_hz']:.1f}", f"{v['mean_hz']:.2f}",
                     f"{v['max_hz']:.1f}") for t, v in sorted(s.get('rates', {}).items())])
    lines += ['', 'Loop periods (ms) and dropped ticks per node:', '']
    lines += table(['node', 'mean', 'p99', 'max', 'late', 'dropped ticks'],
                   [(n, f"{p['mean_s'] * 1e3:.3f}", f"{p['p99_s'] * 1e3:.3f}",
                     f"{p['max_s'] * 1e3:.2f}", f"{p['late_share'] * 100:.2f} %",
                     s['dropped_ticks'].get(n, 0)) for n, p in sorted(s['periods'].items())])
    lag = s.get('lag_s', {})
    lines += ['']
    lines += table(['figure', 'value'], [
        ('messages lost / written', f"{s['lost']} / {s['written']}"),
        ('recorder lag p50 / p99 / max (force)',
         f"{lag.get('p50', float('nan')) * 1e3:.2f} / {lag.get('p99', float('nan')) * 1e3:.2f}"
         f" / {lag.get('max', float('nan')) * 1e3:.1f} ms"),
        ('bag files', s.get('files', 0)),
        ('bag GB/h compressed (zstd) / uncompressed',
         f"{s['bag_gb_h']:.3f} / {s['bag_gb_h_uncompressed']:.3f}"),
        (f"RAM of all processes at {e['hours']} h", f"{e['ram_gb']:.2f} GB"),
        (f"disk at {e['hours']} h compressed / uncompressed",
         f"{e['disk_gb']:.2f} / {e['disk_gb_uncompressed']:.2f} GB")])
    return lines


def soak_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result rows: the worst RSS slope, device rate, losses, 6.1 h RAM and disk."""
    s = r.get('soak')
    if not s:
        return []
    worst = max(s['processes'].items(), key=lambda kv: kv[1]['rss_slope_mb_h'])
    rates = [v for v in s.get('rates', {}).values()]
    lo = min((v['min_hz'] for v in rates), default=float('nan'))
    hi = max((v['max_hz'] for v in rates), default=float('nan'))
    e = s['extrapolated']
    return [
        ('soak: worst RSS slope', '<= 5 MB/h',
            f"{worst[1]['rss_slope_mb_h']:+.2f} MB/h ({worst[0]})", commit),
        ('soak: device rate, 10 s windows', '1000 +- 2 Hz', f'{lo:.1f} .. {hi:.1f} Hz',
            commit),
        ('soak: messages lost', '0', f"{s['lost']} of {s['written']}", commit),
        (f"soak: extrapolated to {e['hours']} h", '<= 2 GB RAM, <= 5 GB disk',
            f"{e['ram_gb']:.2f} GB RAM, {e['disk_gb']:.2f} GB disk", commit),
    ]


STUDY = Study('soak', 'a 20-minute wall-clock isometric run watched from outside: memory, CPU, '
              'device rate, losses, bag size, extrapolated to 6.1 h',
              lambda quick, out, scenes: {'soak': measure_soak(out / 'soak', quick)},
              (('soak', soak_section),), lambda r: soak_results(r, commit_of(r, 'soak')))
"""The soak study (bench.json ``soak``)."""
