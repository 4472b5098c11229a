"""000's straight-fibre muscle through the nodes: `pam-bench run straight_fibre_quick` and
`pam-bench extract` on its bag, end to end; the prototype's figures from the readings."""

from __future__ import annotations

import json
import pathlib
import subprocess
import sys

from pam_bench.bags.bagread import read_bags
from pam_bench.verify.prototype import prototype_figures


def test_quick_campaign_on_the_prototype_and_its_extraction(tmp_path: pathlib.Path,
                                                            ros_domain: int) -> None:
    bag, rep = tmp_path / 'bag', tmp_path / 'report'
    run = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', 'straight_fibre_quick',
                          '--out', str(bag)], capture_output=True, text=True, timeout=240)
    assert run.returncode == 0, run.stdout + run.stderr
    figures = prototype_figures(read_bags([bag]).points, segments=3)
    assert [f['figure'] for f in figures if not f['ok']] == [], figures
    ext = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'extract', str(bag), '--out',
                          str(rep)], capture_output=True, text=True, timeout=240)
    assert ext.returncode == 0, ext.stdout + ext.stderr
    summary = json.loads((rep / 'summary.json').read_text())
    assert summary['model_comparison_length_m'] == 0.25          # read from the bag's run
    laws = {m['model']: m for m in summary['model_comparison']}
    best = min(laws.values(), key=lambda m: m['rmse_N'])
    assert best['model'] == 'straight_fibre'                      # its own law fits best
    assert laws['straight_fibre']['length_rmse_mm'] < 1.0
    assert laws['straight_fibre']['stiffness_rmse_kN_per_m'] is not None
    assert {'loading_stderr', 'unloading_stderr'} <= set(summary['model_comparison_by_branch'][0])
    gain = summary['isometric']['gain_N_per_V']
    assert gain['max'] > gain['min'] > 0
    report = (rep / 'report.md').read_text()
    assert 'length RMSE mm' in report and 'straight_fibre' in report
