"""Packaging of pam_bench (ament_python; also an ordinary pip-installable package)."""

from __future__ import annotations

import os
import runpy
from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'pam_bench'
# the node executables: the one list of them (imports nothing, so read without the package)
HERE = os.path.dirname(os.path.abspath(__file__))
NODES = runpy.run_path(os.path.join(HERE, 'pam_bench', 'config', 'executables.py'))['EXECUTABLES']

setup(
    name=PACKAGE,
    version='0.1.0',
    # the package only: the benchmark studies (benchmarks/) and the tests stay in the clone
    packages=find_packages(include=['pam_bench', 'pam_bench.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml')),
        (f'share/{PACKAGE}/config/scenes', glob('config/scenes/*.yaml')),
        (f'share/{PACKAGE}/config/sweeps', glob('config/sweeps/*.yaml')),
        (f'share/{PACKAGE}/config/foxglove', glob('config/foxglove/*.json')),
        (f'share/{PACKAGE}/config/fastdds', glob('config/fastdds/*.xml')),
        (f'share/{PACKAGE}/config/buses',
         glob('config/buses/*.yaml') + glob('config/buses/*.eds')),
        (f'share/{PACKAGE}/msg_defs/msg', glob('msg_defs/msg/*.msg')),
        (f'share/{PACKAGE}/msg_defs/action', glob('msg_defs/action/*.action')),
    ],
    # rosbags exact: analysis.splitwriter writes through its MCAP storage (test_splitwriter);
    # ruamel.yaml.clib: rosbags reads each bag's metadata.yaml through ruamel, 10x faster on it
    install_requires=['numpy', 'scipy', 'pyyaml', 'rosbags==0.11.9', 'ruamel.yaml.clib', 'mcap',
                      'matplotlib', 'numba', 'dask', 'distributed', 'foxglove-sdk',
                      'pymodbus>=3.16,<4', 'canopen>=2.4,<3', 'python-can>=4.6,<5'],
    zip_safe=True,
    maintainer='pam_bench developers',
    maintainer_email='pam-bench@example.org',
    description='Pneumatic-muscle test bench as ROS 2 nodes, with offline extraction.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [f'{name} = {module}:main' for name, module in NODES.items()]
        + ['pam-bench = pam_bench.cli:command'],
    },
)
