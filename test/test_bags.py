# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Recordings that other tools open: an independent reader (rosbags) decodes every message."""

import subprocess
import sys
from pathlib import Path

import pytest
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rcl_interfaces.msg import ParameterEvent
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from jacket_cloth_ros.ros import cdr, messages


def _jacket_cloth(*args):
    return subprocess.run([sys.executable, '-m', 'jacket_cloth_ros', *args],
                          capture_output=True, text=True, timeout=300)


def _decoded(path):
    """{topic: messages rosbags decoded} of a recording; fails on any it cannot decode."""
    counts = {}
    with AnyReader([Path(path)]) as reader:
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
            counts[connection.topic] = counts.get(connection.topic, 0) + 1
    return counts


def test_clip_files_are_byte_identical_and_every_replayed_message_decodes(tmp_path):
    # JointState went through rclpy's serializer, which leaves padding uninitialised and
    # appends bytes: two runs differed and rosbags refused every JointState.
    one, two, out = tmp_path / 'a' / 'clip.mcap', tmp_path / 'b' / 'clip.mcap', tmp_path / 'r.mcap'
    for path in (one, two):
        path.parent.mkdir()
        assert _jacket_cloth('motion', '--clip', 'dodge', '--duration', '1', '-o',
                             str(path)).returncode == 0
    assert one.read_bytes() == two.read_bytes()
    assert _jacket_cloth('replay', str(one), '-o', str(out)).returncode == 0
    counts = _decoded(out)
    assert counts['/joint_states'] == counts['/tf'] == 61
    assert counts['/jacket_cloth_node/markers'] > 0 and counts['/diagnostics'] > 0


@pytest.mark.parametrize('value', [[1.0, -2.5, 0.0], 'xpbd', 3, 9.5, True, [1, 2], ['a', 'bc']])
def test_recorded_parameter_events_decode_in_rclpy_and_rosbags(value):
    # The node records its parameter changes; rclpy's serializer left them undecodable by
    # rosbags (trailing bytes) and different from run to run (padding).
    changed = [Parameter('p', value=value).to_parameter_msg()]
    data = cdr.parameter_event(12_000_000_123, '/npc1/jacket_cloth_node', changed)
    expected = ParameterEvent(node='/npc1/jacket_cloth_node', changed_parameters=changed)
    expected.stamp = messages.stamp_msg(12_000_000_123)
    assert deserialize_message(data, ParameterEvent) == expected
    store = get_typestore(Stores.ROS2_JAZZY)
    decoded = store.deserialize_cdr(data, 'rcl_interfaces/msg/ParameterEvent')
    assert decoded.changed_parameters[0].name == 'p' and decoded.node == expected.node
