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


def test_a_name_with_a_trailing_separator_is_a_bag_folder_to_the_writer_too(tmp_path):
    # `-o x.mcap/` was a folder to the check and a file to the writer: the rename into place
    # failed with an error naming the tool's temporary folder.
    from jacket_cloth_ros.tools.cli import main
    out = tmp_path / 'session.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '0.5', '-o', f'{out}/']) == 0
    assert sorted(p.name for p in out.iterdir()) == ['metadata.yaml', 'session.mcap_0.mcap']
    assert [p.name for p in tmp_path.iterdir()] == ['session.mcap']


def test_a_bag_folder_is_laid_out_as_rosbag2_does_and_every_reader_opens_it(tmp_path):
    # Without .mcap the output is a bag folder: NAME/NAME_0.mcap and metadata.yaml (version 9,
    # with its files and QoS profiles), as `ros2 bag record -s mcap -o NAME` lays it out.
    import yaml
    from mcap.reader import make_reader
    from rosbags.rosbag2 import Reader
    from jacket_cloth_ros.recording.reader import read_recording
    clip, bag, single = tmp_path / 'clip.mcap', tmp_path / 'session', tmp_path / 'session.mcap'
    assert _jacket_cloth('motion', '--clip', 'walk', '--duration', '1', '-o',
                         str(clip)).returncode == 0
    for out in (bag, single):
        assert _jacket_cloth('replay', str(clip), '-o', str(out)).returncode == 0
    assert sorted(p.name for p in bag.iterdir()) == ['metadata.yaml', 'session_0.mcap']
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9 and info['relative_file_paths'] == ['session_0.mcap']
    assert info['files'][0]['path'] == 'session_0.mcap'
    assert info['files'][0]['message_count'] == info['message_count']
    for topic in info['topics_with_message_count']:
        qos = topic['topic_metadata']['offered_qos_profiles']
        assert isinstance(qos, list) and qos[0]['reliability'] in ('reliable', 'best_effort')
    with Reader(bag) as reader:             # rosbags' rosbag2 reader: folder and metadata
        assert reader.message_count == info['message_count']
        decoded = sum(1 for _ in reader.messages())
    assert decoded == info['message_count']
    assert _decoded(bag / 'session_0.mcap') == _decoded(single)
    with open(bag / 'session_0.mcap', 'rb') as f:      # mcap with its CRCs checked
        assert sum(1 for _ in make_reader(f, validate_crcs=True).iter_messages()) == decoded
    ours = read_recording(str(bag))
    assert ours.complete and ours.path == str(bag)
    # A bag folder is not overwritten without --force, and a plain folder never.
    assert _jacket_cloth('replay', str(clip), '-o', str(bag)).returncode == 1
    assert _jacket_cloth('replay', str(clip), '-o', str(bag), '--force').returncode == 0
    assert (bag / 'metadata.yaml').exists() and not list(tmp_path.glob('.session.*'))
    # Never the folder that holds the input, even with --force.
    inner = bag / 'session_0.mcap'
    kept = inner.read_bytes()
    assert _jacket_cloth('replay', str(inner), '-o', str(bag), '--force').returncode == 1
    assert inner.read_bytes() == kept
