# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's own CDR reading of JointState, held to rclpy's decoding; what its markers show."""

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.simulation import JacketSimulation
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
from jacket_cloth_ros.core.transforms import quat_to_matrix
from jacket_cloth_ros.ros import messages
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


def test_collider_and_hood_markers_sit_where_the_simulation_has_them():
    # The example rig has ellipsoids, capsules and the floor; its markers are posed by compiled
    # code (marker_kernel), held here to the collider frames the cloth collides with.
    with open(shipped('examples/mannequin.urdf'), encoding='utf-8') as f:
        skeleton = Skeleton(f.read())
    rig = load_rig(skeleton, shipped('examples/mannequin_rig.yaml'))
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'))
    q = np.zeros(len(skeleton.joint_names))
    q[skeleton.joint_index['LeftUpLeg_swing']] = -0.9       # a thigh capsule off the vertical
    tilt = np.array([0.1, 0.05, 0.2, 0.97])           # leaning and turned: in the root frame
    world = [0.3, 0.0, 0.96] + list(tilt / np.linalg.norm(tilt))    # the floor is tilted
    names = list(skeleton.joint_names) + [f'world_joint/{v}' for v in WORLD_VARIABLES]
    assert sim.process(10 ** 9, names, list(q) + world).accepted
    c = sim.collider_frames(sim.links)
    shown = {(m.ns, m.id): m for m in messages.marker_specs(sim, debug=True)}
    for k in range(len(c.centers)):                         # ellipsoids: scaled spheres
        m = shown['colliders', k]
        assert m.type == messages.SPHERE and np.allclose(m.position, c.centers[k])
        assert np.allclose(quat_to_matrix(m.orientation), c.axes[k])
        assert np.allclose(m.scale, 2 * c.radii[k])
    at = len(c.centers)
    assert len(c.capsule_a) == 2 and len(c.plane_points) == 1
    for a, b, r in zip(c.capsule_a, c.capsule_b, c.capsule_radii):
        body, end_a, end_b = (shown['colliders', at + i] for i in range(3))
        axis = b - a
        assert body.type == messages.CYLINDER and np.allclose(body.position, (a + b) / 2)
        assert np.allclose(quat_to_matrix(body.orientation)[:, 2], axis / np.linalg.norm(axis))
        assert np.allclose(body.scale, (2 * r, 2 * r, np.linalg.norm(axis)))
        assert np.allclose(end_a.position, a) and np.allclose(end_b.position, b)
        at += 3
    floor = shown['colliders', at]
    n = c.plane_normals[0]
    assert abs(n[0]) > 0.05 and abs(n[1]) > 0.05
    assert floor.type == messages.CUBE and np.allclose(quat_to_matrix(floor.orientation)[:, 2], n)
    assert np.allclose(floor.position, (c.plane_points[0] @ n) * n)   # in the plane
    assert np.allclose(shown['hood', 1].position, sim.hood_p)
    anchor, _ = sim.hood_anchor(sim.links)
    assert np.allclose(shown['hood', 0].points, [anchor, sim.hood_p])
    bones = shown['jacket_bones', 0].points
    assert np.allclose(bones[0::2], sim.layer.positions)
    assert np.allclose(bones[1::2], sim.layer.tips)


def test_read_markers_reads_what_rclpy_reads_without_an_object_per_point():
    # picture and the animation read recorded markers with read_markers, arrays over the
    # bytes: rclpy's deserialize_message took most of a session's animation. Every marker of
    # a reset array with the debug layer and the body, as rclpy reads it.
    from rclpy.serialization import deserialize_message
    from visualization_msgs.msg import MarkerArray
    from jacket_cloth_ros.ros.cdr import read_markers
    with open(shipped('examples/mannequin.urdf'), encoding='utf-8') as f:
        skeleton = Skeleton(f.read())
    rig = load_rig(skeleton, shipped('examples/mannequin_rig.yaml'))
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'))
    raw = messages.marker_array(sim, 7, 'root', reset=True, debug=True, body=True)
    ours, theirs = read_markers(raw), deserialize_message(raw, MarkerArray).markers
    assert len(ours) == len(theirs) > 10
    for a, b in zip(ours, theirs):
        assert (a.ns, a.id, a.type, a.action) == (b.ns, b.id, b.type, b.action)
        points = np.array([[p.x, p.y, p.z] for p in b.points]).reshape(-1, 3)
        colors = np.array([[c.r, c.g, c.b, c.a] for c in b.colors], dtype=np.float32)
        assert np.array_equal(a.points, points)
        assert np.array_equal(a.colors, colors.reshape(-1, 4))
    assert {a.ns for a in ours if len(a.points)} >= {'jacket', 'cloth', 'hood'}
    with pytest.raises(ValueError):
        read_markers(raw[:len(raw) // 2])
