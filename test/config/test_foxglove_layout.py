"""The shipped Foxglove layout plots fields the bench's messages have, on topics the live view
serves."""

from __future__ import annotations

import json
import pathlib
import re

import pytest

from pam_bench.bags.types import bench_typestore
from pam_bench.bringup.live import live_topics
from pam_bench.config.scene import load_scene

LAYOUT = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'foxglove' / \
    'pam_bench_layout.json'


def _paths(layout: dict) -> list[str]:
    out = []
    for panel in layout['configById'].values():
        out += [p['value'] for p in panel.get('paths', [])]
        if 'xAxisPath' in panel:
            out.append(panel['xAxisPath']['value'])
        if 'topicPath' in panel:
            out.append(panel['topicPath'])
    return out


def _resolve(store: object, msgtype: str, fields: list[str]) -> None:
    """Walk ``fields`` (``name`` or ``name[i]``) through ``msgtype``; raise KeyError if one is
    missing."""
    for name in fields:
        base = re.sub(r'\[\d+\]$', '', name)
        fdefs = dict(store.fielddefs[msgtype][1])  # type: ignore[attr-defined]
        kind = fdefs[base]
        node = kind[1] if kind[0].name in ('SEQUENCE', 'ARRAY') else kind
        node = node[0] if isinstance(node, tuple) and node and isinstance(node[0], tuple) \
            else node
        msgtype = node[1] if node[0].name == 'NAME' else ''


@pytest.mark.parametrize('path', _paths(json.loads(LAYOUT.read_text())))
def test_every_path_names_a_served_topic_and_a_field(path: str) -> None:
    served = dict(e.split(':', 1) for e in live_topics(load_scene('campaign_quick').settings()))
    topic, _, rest = path.partition('.')
    assert topic in served, f'{topic} is not served by the live view'
    _resolve(bench_typestore(), served[topic], rest.split('.') if rest else [])
