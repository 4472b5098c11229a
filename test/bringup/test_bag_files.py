"""The recorder's files as a lab meets them: a lock-step campaign recorded compressed and split
extracts to the same summary as the same run recorded uncompressed in one file."""

from __future__ import annotations

import pathlib
import subprocess
import sys
from typing import Any

from ruamel.yaml import YAML

from pam_bench.analysis.extract import extract


def _run(scene: str, out: pathlib.Path, *flags: str) -> None:
    res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', scene, '--out',
                          str(out), *flags], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr


def _results(summary: dict[str, Any]) -> dict[str, Any]:
    """What the bags say, without how long the fits took or where the bags lay."""
    out = {k: v for k, v in summary.items() if k not in ('timing_s', 'bags', 'runs')}
    out['model_comparison'] = [{k: v for k, v in m.items() if k != 'fit_s'}
                               for m in out.get('model_comparison', [])]
    return out


def test_split_compressed_bag_extracts_as_one_plain_file(tmp_path: pathlib.Path,
                                                          ros_domain: int) -> None:
    split, plain = tmp_path / 'split', tmp_path / 'plain'
    _run('campaign_quick', split, '--max-bag-duration', '60s', '--max-bag-size', '200k')
    _run('campaign_quick', plain, '--no-compress', '--max-bag-size', '0')
    meta = YAML(typ='safe').load((split / 'metadata.yaml').read_text())
    files = meta['rosbag2_bagfile_information']['relative_file_paths']
    assert len(files) >= 5 and sorted(files) == sorted(f.name for f in split.glob('*.mcap'))
    assert [f.name for f in plain.glob('*.mcap')] == ['plain.mcap']
    split_bytes = sum(f.stat().st_size for f in split.glob('*.mcap'))
    assert split_bytes < 0.5 * (plain / 'plain.mcap').stat().st_size
    a = extract([str(split)], str(tmp_path / 'a'), figures=False)
    b = extract([str(plain)], str(tmp_path / 'b'), figures=False)
    assert _results(a) == _results(b)
    assert a['isometric'] and a['step_response']
