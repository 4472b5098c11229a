"""Every module pam_bench imports at run time is declared: in setup.py's install_requires (a
wheel installs it) and in package.xml (rosdep installs it), ROS packages in package.xml."""

from __future__ import annotations

import ast
import importlib.metadata
import pathlib
import re
import sys

REPO = pathlib.Path(__file__).resolve().parents[2]
ROS = re.compile(r'^(rclpy|rcl_interfaces|rosidl_\w+|rosgraph_msgs|builtin_interfaces|'
                 r'\w+_msgs|\w+_srvs|\w+_interfaces)$')

ROSDEP_KEYS = {'pyyaml': 'python3-yaml', 'python-can': 'python3-can'}
"""rosdep keys that are not python3-DIST."""


def _imported() -> set[str]:
    """The top-level names of every module pam_bench imports (at any depth of the code)."""
    out: set[str] = set()
    for path in (REPO / 'pam_bench').rglob('*.py'):
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            if isinstance(node, ast.Import):
                out |= {a.name.split('.')[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                out.add(node.module.split('.')[0])
    return out - set(sys.stdlib_module_names) - {'pam_bench', '__future__'}


def _norm(name: str) -> str:
    return re.sub(r'[-_.]+', '-', name).lower()


def _install_requires() -> set[str]:
    text = (REPO / 'setup.py').read_text(encoding='utf-8')
    block = text.split('install_requires=[', 1)[1].split(']', 1)[0]
    return {_norm(re.split(r'[<>=!~ ]', r)[0]) for r in re.findall(r"'([^']+)'", block)}


def _package_xml() -> set[str]:
    text = (REPO / 'package.xml').read_text(encoding='utf-8')
    return set(re.findall(r'<(?:exec_)?depend>([^<]+)</(?:exec_)?depend>', text))


def test_every_runtime_import_is_declared() -> None:
    dists = importlib.metadata.packages_distributions()
    requires, xml = _install_requires(), _package_xml()
    missing = []
    for module in sorted(_imported()):
        if ROS.match(module):
            if module not in xml:
                missing.append(f'{module}: not an exec_depend of package.xml')
            continue
        names = dists.get(module)
        assert names, f'{module} is imported but not installed here'
        dist = _norm(names[0])
        if dist not in requires:
            missing.append(f'{module} ({dist}): not in install_requires')
        if not {f'python3-{dist}', f'python3-{dist}-pip', ROSDEP_KEYS.get(dist)} & xml:
            missing.append(f'{module} ({dist}): no python3-{dist}[-pip] exec_depend')
    assert not missing, '\n'.join(missing)
