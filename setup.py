"""Packaging of pam_bench (ament_python; also an ordinary pip-installable package)."""

from __future__ import annotations

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'pam_bench'
NODES = {
    'sim_clock': 'pam_bench.nodes.sim_clock',
    'valve_sim': 'pam_bench.nodes.valve_sim',
    'muscle_sim': 'pam_bench.nodes.muscle_sim',
    'load_cell_sim': 'pam_bench.nodes.load_cell_sim',
    'encoder_sim': 'pam_bench.nodes.encoder_sim',
    'loading_servo_sim': 'pam_bench.nodes.loading_servo_sim',
    'sequencer': 'pam_bench.nodes.sequencer',
    'recorder': 'pam_bench.nodes.recorder',
    'torque_servo': 'pam_bench.nodes.torque_servo',
}

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*']),
    package_data={'pam_bench.benchmarks': ['methods.yaml']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml')),
        (f'share/{PACKAGE}/config/scenes', glob('config/scenes/*.yaml')),
        (f'share/{PACKAGE}/msg_defs/msg', glob('msg_defs/msg/*.msg')),
        (f'share/{PACKAGE}/msg_defs/action', glob('msg_defs/action/*.action')),
    ],
    install_requires=['numpy', 'scipy', 'pyyaml', 'rosbags', 'matplotlib'],
    zip_safe=True,
    maintainer='pam_bench developers',
    maintainer_email='pam-bench@example.org',
    description='Pneumatic-muscle test bench as ROS 2 nodes, with offline extraction.',
    license='Apache-2.0',
    entry_points={
        'console_scripts': [f'{name} = {module}:main' for name, module in NODES.items()]
        + ['pam-bench = pam_bench.cli:main'],
    },
)
