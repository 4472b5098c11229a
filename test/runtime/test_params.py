"""Every node declares exactly its settings dataclass: same names, same defaults, one owner."""

from __future__ import annotations

import ast
import importlib
import pathlib

import pytest
import rclpy

from pam_bench.config.nodes import NODES
from pam_bench.runtime import intra
from pam_bench.vocabulary.params import flat_infos

NODES_DIR = pathlib.Path(__file__).resolve().parents[2] / 'pam_bench' / 'nodes'
ROS_OWN = {'use_sim_time', 'start_type_description_service'}   # rclpy's own, on every node


@pytest.mark.parametrize('name', sorted(NODES))
def test_declared_parameters_are_the_settings_dataclass(name: str, ros_domain: int,
                                                        tmp_path: pathlib.Path) -> None:
    t = NODES[name]
    cls = getattr(importlib.import_module(t.module), t.cls)
    context = rclpy.Context()
    rclpy.init(context=context)
    bus = intra.IntraProcessBus()      # composed: no DDS entity waits for a peer
    node = None
    try:
        from rclpy.parameter import Parameter
        # what a node cannot start without: a bag folder to create, an inverse model to load
        need = {'recorder': [Parameter('out_dir', value=str(tmp_path / 'bag'))],
                'torque_servo': [Parameter('controller', value='pid')]}
        overrides = need.get(name, [])
        node = cls(name, context=context, parameter_overrides=overrides, bus=bus)
        declared = set(node.list_parameters([], 0).names) - ROS_OWN
        infos = {i.name: i for i in flat_infos(t.settings)}
        assert declared == set(infos), (declared ^ set(infos))
        for key, info in infos.items():
            if key in ('out_dir', 'controller'):
                continue
            value = node.get_parameter(key).value
            if isinstance(info.default, list):
                value = [v for v in value if v != '']
                assert list(value) == pytest.approx(info.default), key
            else:
                assert value == info.default, key
        # and the node's settings object is the dataclass with those values
        assert type(node.settings) is t.settings
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=context)
    assert bus is not None


def _calls(path: pathlib.Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding='utf-8'))
    return [n.func.attr for n in ast.walk(tree)
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute)]


@pytest.mark.parametrize('path', sorted(NODES_DIR.glob('*.py')), ids=lambda p: p.name)
def test_no_node_declares_a_parameter_of_its_own(path: pathlib.Path) -> None:
    """A default written beside a node would be a second owner: only ``runtime.params``
    declares, from the dataclass."""
    if path.name == 'params.py':
        return
    calls = _calls(path)
    assert 'declare_parameter' not in calls and 'declare_parameters' not in calls
