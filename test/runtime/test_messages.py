"""Message helpers: ``import_rosidl_lean`` loads type support without ROS's code generator."""

from __future__ import annotations

import subprocess
import sys

PROBE = """
import sys
from pam_bench.runtime.messages import import_rosidl_lean
import_rosidl_lean()
import rclpy
from rclpy.type_support import check_for_type_support
from geometry_msgs.msg import WrenchStamped
check_for_type_support(WrenchStamped)              # what a publisher's creation does
print(sorted(m for m in ('em', 'lark', 'rosidl_parser.parser') if m in sys.modules))
print('rosidl_generator_py.generate_py_impl' in sys.modules)
from rosidl_generator_py.generate_py_impl import generate_py   # still there when asked for
print(callable(generate_py))
"""


def test_type_support_loads_without_the_code_generator() -> None:
    out = subprocess.run([sys.executable, '-c', PROBE], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split('\n')[:3] == ['[]', 'False', 'True'], out.stdout


def test_without_it_the_generator_is_imported() -> None:
    """The control: the same probe without the call imports empy and lark."""
    probe = PROBE.replace('import_rosidl_lean()\n', '')
    out = subprocess.run([sys.executable, '-c', probe], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split('\n')[0] == "['em', 'lark', 'rosidl_parser.parser']", out.stdout
