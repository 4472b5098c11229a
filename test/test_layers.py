"""The house: every folder one role, no import from a layer above, no rclpy below the nodes."""

from __future__ import annotations

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1] / 'pam_bench'
# lower rank = lower layer; a module may import its own folder and lower ranks only
RANK = {'vocabulary': -1, 'models': 0, 'sim': 1, 'control': 1, 'cluster': 1, 'protocol': 2,
        'config': 3, 'buses': 3.5, 'bags': 3.8, 'analysis': 4, 'live': 5, 'runtime': 5.5,
        'nodes': 6, 'twin': 6, 'verify': 7, 'fit': 7.5, 'bringup': 8, 'sweep': 9, 'cli': 11}
NO_ROS = {'vocabulary', 'models', 'sim', 'control', 'cluster', 'protocol', 'config', 'buses',
          'bags', 'analysis', 'live', 'twin', 'verify', 'fit'}
MODULES = sorted(p for p in ROOT.rglob('*.py'))


def _room(path: pathlib.Path) -> str:
    rel = path.relative_to(ROOT).parts
    return rel[0] if len(rel) > 1 else rel[0].removesuffix('.py')


def _imports(path: pathlib.Path) -> list[str]:
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.append(node.module)
    return out


def test_every_folder_is_a_known_room() -> None:
    rooms = {p.name for p in ROOT.iterdir() if p.is_dir() and p.name != '__pycache__'}
    assert rooms == set(RANK)


@pytest.mark.parametrize('path', MODULES, ids=[str(p.relative_to(ROOT)) for p in MODULES])
def test_no_import_from_a_layer_above(path: pathlib.Path) -> None:
    room = _room(path)
    if room == '__init__':
        return
    for name in _imports(path):
        parts = name.split('.')
        if parts[0] == 'rclpy' or parts[0].startswith('rosgraph') or parts[0] == 'rcl_interfaces':
            assert room not in NO_ROS, f'{path.name} imports {name}'
        assert parts[0] != 'benchmarks', f'{path.name} imports the studies ({name})'
        if parts[0] != 'pam_bench' or len(parts) < 2:
            continue
        other = parts[1]
        if other == room:
            continue
        assert RANK[other] < RANK[room], f'{room}/{path.name} imports {name}'


@pytest.mark.parametrize('init', sorted(ROOT.rglob('__init__.py')),
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_every_package_has_a_one_line_docstring_and_all(init: pathlib.Path) -> None:
    tree = ast.parse(init.read_text(encoding='utf-8'))
    doc = ast.get_docstring(tree)
    assert doc and '\n' not in doc.strip()
    names = [t.id for n in tree.body if isinstance(n, ast.Assign) for t in n.targets
             if isinstance(t, ast.Name)]
    assert '__all__' in names


def test_every_folder_is_a_package() -> None:
    for folder in {p.parent for p in MODULES}:
        assert (folder / '__init__.py').is_file(), folder


def _module_name(path: pathlib.Path) -> str:
    rel = path.relative_to(ROOT.parent).with_suffix('')
    parts = list(rel.parts)
    if parts[-1] == '__init__':
        parts = parts[:-1]
    return '.'.join(parts)


def test_no_import_circle_between_modules() -> None:
    """No module imports, directly or through others, one that imports it back (function-level
    imports included: a lazy import still ties the two)."""
    names = {_module_name(p): p for p in MODULES}
    graph: dict[str, set[str]] = {}
    for name, path in names.items():
        deps = set()
        for imp in _imports(path):
            while imp and imp not in names:
                imp = imp.rpartition('.')[0]
            if imp and imp != name and not name.startswith(imp + '.') and \
                    not imp.endswith('__main__'):
                deps.add(imp)
        graph[name] = deps
    # a package's __init__ re-exporting its own modules is not a circle
    for name in graph:
        graph[name] = {d for d in graph[name] if not (names[d].name == '__init__.py'
                                                      and name.startswith(d + '.'))}
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> None:
        state[n] = 1
        stack.append(n)
        for d in sorted(graph.get(n, ())):
            if state.get(d) == 1:
                cycle = stack[stack.index(d):] + [d]
                raise AssertionError('import circle: ' + ' -> '.join(cycle))
            if d not in state:
                visit(d)
        stack.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)


STUDIES = pathlib.Path(__file__).resolve().parents[1] / 'benchmarks'


@pytest.mark.parametrize('path', sorted(STUDIES.glob('*.py')), ids=lambda p: p.name)
def test_the_studies_sit_above_the_package(path: pathlib.Path) -> None:
    """The benchmark studies (top-level ``benchmarks/``, not in the wheel) import pam_bench and
    each other, never a node's ROS client library directly."""
    for name in _imports(path):
        assert name.split('.')[0] not in ('rclpy', 'rosgraph_msgs'), f'{path.name}: {name}'


def test_every_study_module_is_named_as_its_key() -> None:
    """One name per study: ``benchmarks/KEY.py`` exports ``STUDY`` with that key."""
    import importlib

    from benchmarks.studies import STUDIES as ALL
    for study in ALL:
        module = importlib.import_module(f'benchmarks.{study.key}')
        assert module.STUDY is study, study.key
