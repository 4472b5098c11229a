"""The recorder's files as a lab meets them: a lock-step campaign recorded compressed and split
extracts to the same summary as the same run recorded uncompressed in one file."""

from __future__ import annotations

import pathlib
import subprocess
import sys
from typing import Any

import pytest
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
    # every other reader of a bag: info, diff, --replay's run description, --resume
    from pam_bench.bags.baginfo import bag_info, run_of_bag
    from pam_bench.bringup.resume import resume_reading
    from pam_bench.cli import main
    from pam_bench.config.scene import load_scene
    assert bag_info(str(split))['end']['state'] == bag_info(str(plain))['end']['state'] == 'done'
    assert run_of_bag(split)['scene'] == run_of_bag(plain)['scene'] == 'campaign_quick'
    scene = load_scene('campaign_quick')
    assert resume_reading(scene, split) == resume_reading(scene, plain)
    assert main(['info', str(split)]) == 0
    assert main(['diff', str(split), str(plain)]) == 0      # the same readings


def test_a_disk_filling_up_ends_the_run_with_a_valid_bag_and_one_line(
        tmp_path: pathlib.Path, ros_domain: int, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Composed in this process, the recorder's disk reports 10 MB free after a while: the
    recorder closes the bag with what it holds and the run ends with exit code 2."""
    from pam_bench.bags import splitwriter
    from pam_bench.bags.baginfo import bag_info
    from pam_bench.bringup.runner import run_scene
    from pam_bench.config.scene import load_scene
    from pam_bench.vocabulary.run import RunOptions
    calls = [0]

    def free(path: pathlib.Path) -> int:
        calls[0] += 1
        return 10**12 if calls[0] < 8 else 10_000_000

    monkeypatch.setattr(splitwriter, 'free_bytes', free)
    bag = tmp_path / 'bag'
    res = run_scene(load_scene('demo'), str(bag), RunOptions(quiet=True))
    err = capsys.readouterr().err
    assert res.code == 2
    lines = [ln for ln in err.splitlines() if 'disk full' in ln]
    assert len(lines) == 1 and 'the bag is closed with the' in lines[0], err
    info = bag_info(str(bag))                        # valid, with what it holds
    assert 0 < info['topics']['/load_cell_1/force']['count'] < 1000
