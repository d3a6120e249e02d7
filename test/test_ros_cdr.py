# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's own CDR reading of JointState, held to rclpy's decoding."""

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from jacket_cloth_ros.ros.cdr import DECODE_ERRORS, JointStateReader


def _joint_state(frame, names, positions, sec=12, nanosec=345):
    msg = JointState()
    msg.header.frame_id = frame
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.name = names
    msg.position = positions
    msg.velocity = [0.5] * len(names)       # read past, never used
    msg.effort = [1.5] * len(names)
    return serialize_message(msg)


def test_reader_equals_rclpy_and_recognises_a_repeated_name_list():
    reader = JointStateReader()
    names = ['hip', 'knee_left', 'a', 'world_joint/rot_w']      # odd lengths: padding
    for frame, positions in (('', [0.1, -2.0, 3.5, 1.0]), ('odd', [1e-300, 0.0, -0.0, 7.0]),
                             ('base_link', [4.0, 5.0, 6.0, 7.0])):
        got = reader.read(_joint_state(frame, names, positions, 1_700_000_000, 999_999_999))
        assert got.stamp_ns == 1_700_000_000 * 10 ** 9 + 999_999_999
        assert got.name == tuple(names)
        assert np.array_equal(got.position, positions)
    # A new name list is decoded afresh, not mistaken for the cached one.
    got = reader.read(_joint_state('', ['hip', 'knee'], [1.0, 2.0]))
    assert got.name == ('hip', 'knee') and got.position.tolist() == [1.0, 2.0]
    assert reader.read(_joint_state('', [], [])).name == ()


@pytest.mark.parametrize('cut', [0, 3, 15, 30, 50])
def test_cut_or_foreign_bytes_raise_a_decode_error(cut):
    raw = _joint_state('base_link', ['hip', 'knee'], [1.0, 2.0])
    with pytest.raises(DECODE_ERRORS):
        JointStateReader().read(raw[:cut] if cut else b'\x07\x07' + raw[2:])
