"""The bench's typestores (``bags.types``): the few types of a run, read from their .msg
files, against the whole Jazzy store."""

from __future__ import annotations

import pathlib

import pytest

from pam_bench.bags.types import PACKAGE, bench_typestore, msg_defs_dir, typestore_of
from pam_bench.config import topics

BENCH_TYPES = sorted({t.msgtype for t in topics.TOPICS}
                     | {e.partition(':')[2] for e in topics.EVENT_TOPICS}
                     | {f'{PACKAGE}/msg/{p.stem}' for p in msg_defs_dir().glob('*.msg')})


def test_every_type_of_the_bench_has_its_definition_and_hash_from_the_whole_store() -> None:
    """What a bag stores of each type (message definition text, RIHS01 hash) is the same from
    either store: a lock-step run's bag does not change with the store it was written with."""
    full, light = bench_typestore(), typestore_of(tuple(BENCH_TYPES))
    assert light is not full
    assert len(BENCH_TYPES) >= 15
    for msgtype in BENCH_TYPES:
        assert light.generate_msgdef(msgtype, ros_version=2) == \
            full.generate_msgdef(msgtype, ros_version=2), msgtype
        assert light.hash_rihs01(msgtype) == full.hash_rihs01(msgtype), msgtype
    assert len(light.fielddefs) < len(full.fielddefs) / 4


def test_a_type_without_a_msg_file_gets_the_whole_store() -> None:
    assert typestore_of(('sensor_msgs/msg/JointState', 'lab_msgs/msg/Nowhere')) \
        is bench_typestore()
    assert typestore_of(('not a type',)) is bench_typestore()


def test_a_lab_package_on_the_ament_prefix_path_is_read(tmp_path: pathlib.Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """A lab's own message package, found where ROS finds it (``AMENT_PREFIX_PATH``)."""
    folder = tmp_path / 'share' / 'lab_msgs' / 'msg'
    folder.mkdir(parents=True)
    (folder / 'Grip.msg').write_text('std_msgs/Header header\nfloat64[3] force_n\n',
                                     encoding='utf-8')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    store = typestore_of(('lab_msgs/msg/Grip',))
    assert store is not bench_typestore()
    text = store.generate_msgdef('lab_msgs/msg/Grip', ros_version=2)[0]
    assert 'float64[3] force_n' in text and 'builtin_interfaces/Time stamp' in text


def test_a_ros_type_is_read_beside_the_python_package_this_process_imports(
        tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Another ROS install on ``AMENT_PREFIX_PATH`` (a workspace of another distro sourced)
    does not change the definition of the messages this process publishes."""
    folder = tmp_path / 'share' / 'sensor_msgs' / 'msg'
    folder.mkdir(parents=True)
    (folder / 'FluidPressure.msg').write_text('float32 fluid_pressure\n', encoding='utf-8')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    typestore_of.cache_clear()
    try:
        store = typestore_of(('sensor_msgs/msg/FluidPressure',))
        assert store.generate_msgdef('sensor_msgs/msg/FluidPressure', ros_version=2) == \
            bench_typestore().generate_msgdef('sensor_msgs/msg/FluidPressure', ros_version=2)
    finally:
        typestore_of.cache_clear()
