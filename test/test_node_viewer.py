# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's ~/viewer (issue 19 item 5): the level of detail set over real DDS, in-process."""

import math

import numpy as np
import rclpy
from conftest import DOMAIN_ID
from rclpy.context import Context
from rclpy.serialization import serialize_message
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped
from test_node import _all_finite

from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.recording.reader import read_messages
from jacket_cloth_ros.ros.viewer import VIEWER_QOS, read_viewer

TOPIC = '/jacket_cloth_node/viewer'
FAR = (0.0, 100.0, 0.0)         # beyond lod_distances[1] (30 m) from the walking character
NEAR = (0.0, 1.0, 0.0)


def _viewer(point, frame='world'):
    msg = PointStamped()
    msg.header.frame_id = frame
    msg.point.x, msg.point.y, msg.point.z = point
    return msg


def _walk(h, first, count):
    """Send inputs ``first`` .. ``first + count - 1`` of a 60 Hz walk, each processed."""
    for k in range(first, first + count):
        names, pos = joint_state_content(h.c.sim.skeleton.joint_names, 'walk', k / 60)
        h.send(names, pos, 100 * 10 ** 9 + k * 10 ** 9 // 60)
        h.spin_until(lambda: h.c.inputs == k + 1)


def _status(diagnostics):
    return {kv.key: kv.value for kv in diagnostics[-1].status[0].values}


def _far_viewer(h, qos):
    """Publish a far viewer with ``qos`` once the node matches it; returns once it is taken."""
    pub = h.peer.create_publisher(PointStamped, TOPIC, qos)
    h.spin_until(lambda: pub.get_subscription_count() > 0)
    pub.publish(_viewer(FAR))
    h.spin_until(lambda: h.node.received['viewer'] == 1)
    return pub


def test_read_viewer_refuses_with_a_reason_and_never_raises():
    good = serialize_message(_viewer((1.0, 2.0, 3.0)))
    assert list(read_viewer(good, 'world').position) == [1.0, 2.0, 3.0]
    for raw, words in [
            (serialize_message(_viewer((1.0, 2.0, 3.0), 'map')), "'map' is not"),
            (serialize_message(_viewer((math.nan, 0.0, 0.0))), 'non-finite'),
            (serialize_message(_viewer((0.0, -math.inf, 0.0))), 'non-finite'),
            (serialize_message(_viewer((0.0, 0.0, 2e9))), 'farther than'),
            (b'\x00\x01\x00\x00' + b'\xff' * 40, 'does not decode'),
            (good[:len(good) - 9], 'does not decode'),
            (b'', 'does not decode')]:
        reading = read_viewer(raw, 'world')
        assert reading.position is None and words in reading.reason, (raw, reading)


def test_a_viewer_latched_before_the_node_starts_sets_its_level_of_detail(harness):
    """Published once (transient local) before the node exists: its first inputs run far."""
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    talker = rclpy.create_node('viewer_talker', context=ctx)
    try:
        talker.create_publisher(PointStamped, TOPIC, VIEWER_QOS).publish(_viewer(FAR))
        h = harness()
        diagnostics = []
        h.peer.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
        h.spin_until(lambda: h.node.received['viewer'] == 1)
        assert h.c.sim.last is None           # before the first input
        h.send_clip('walk', 60, 1.0)
        h.spin_until(lambda: len(diagnostics) >= 1)
        assert h.c.sim.lod.level == 2 and h.node.refused['viewer'] == 0
        values = _status(diagnostics)
        assert values['lod_level'] == '2'
        assert 95.0 < float(values['viewer_distance_m']) < 105.0
    finally:
        talker.destroy_node()
        rclpy.shutdown(context=ctx)


def test_a_bad_viewer_is_ignored_with_a_warning_and_the_node_keeps_publishing(harness):
    h = harness()
    pub = _far_viewer(h, VIEWER_QOS)
    h.send_clip('walk', 60, 0.5)
    assert h.c.sim.lod.level == 2
    # Each would bring the viewer near (or break the distance) if it were taken.
    bad = [serialize_message(_viewer(NEAR, 'map')),
           serialize_message(_viewer((math.nan, 1.0, 0.0))),
           serialize_message(_viewer((0.0, 0.0, 1e12))),
           b'\x00\x01\x00\x00' + b'\xff' * 40]
    for k, raw in enumerate(bad):
        pub.publish(raw)
        h.spin_until(lambda: h.node.received['viewer'] == k + 2)
    assert h.node.refused['viewer'] == len(bad) and 'viewer' in h.node._log_times
    assert list(h.c.sim.lod.viewer) == list(FAR)
    before = len(h.tf)
    sent = h.send_clip('walk', 60, 0.5, start_s=100.5)
    h.spin_until(lambda: len(h.tf) >= before + sent - 2)
    assert h.c.sim.lod.level == 2 and all(_all_finite(tf) for tf in h.tf)


def test_a_live_session_near_far_near_replays_byte_for_byte(harness, tmp_path):
    """The viewer moves near -> far -> near during a recorded live session; the replay, from
    the file alone, applies each viewer at the same input: every /tf and marker the same."""
    from jacket_cloth_ros.tools.session import load_session, run_session
    path = tmp_path / 'live.mcap'
    h = harness(record=str(path))
    pub = h.peer.create_publisher(PointStamped, TOPIC, VIEWER_QOS)
    h.spin_until(lambda: pub.get_subscription_count() > 0)
    levels = []
    for k, point in enumerate([NEAR, FAR, NEAR]):
        pub.publish(_viewer(point))
        h.spin_until(lambda: h.node.received['viewer'] == k + 1)
        _walk(h, 48 * k, 48)
        levels.append(h.c.sim.lod.level)
    assert levels == [0, 2, 0] and h.c.sim.resets == 1       # the first input's only
    h.node.close()
    session = load_session(str(path))
    assert [e[2] for e in session.events].count('viewer') == 3
    recorded = {}
    for m in read_messages(session.recording.path)[0]:
        if m.topic in ('/tf', '/jacket_cloth_node/markers'):
            recorded.setdefault(m.topic, []).append(m.data)
    replayed, replay_levels = {'/tf': [], '/jacket_cloth_node/markers': []}, []

    def probe(pipeline, report, stamp, outs):
        replay_levels.append(report.lod_level)
        for key, data in outs:
            if key != 'diagnostics':
                replayed['/tf' if key == 'tf' else '/jacket_cloth_node/markers'].append(data)
    run_session(session, probe=probe)
    assert len(recorded['/tf']) == 3 * 48 and replayed == recorded
    # The level changes during the session, at the inputs the live node changed it.
    assert replay_levels[:48] == [0] * 48 and replay_levels[-1] == 0
    assert replay_levels[48:96] == [2] * 48


def test_a_recording_started_after_the_viewer_replays_from_it(harness, tmp_path):
    """`record` set live while a far viewer stands: the file starts with that viewer, so
    its replay runs far from its first input, as the node did."""
    from jacket_cloth_ros.tools.session import load_session, run_session
    from rclpy.parameter import Parameter
    path = tmp_path / 'late.mcap'
    h = harness()
    _far_viewer(h, VIEWER_QOS)
    _walk(h, 0, 30)
    assert h.node.set_parameters([Parameter('record', value=str(path))])[0].successful
    _walk(h, 30, 30)
    h.node.close()
    session = load_session(str(path))
    assert [e[2] for e in session.events][0] == 'viewer'
    levels = []
    run_session(session, probe=lambda p, r, stamp, outs: levels.append(r.lod_level))
    assert levels[1:] == [2] * 29          # the first input starts the cloth: no steps


def test_a_root_far_off_gives_the_far_level_without_an_overflow():
    # Found by the ~/viewer fuzz: a finite but huge root position overflowed numpy's norm.
    import warnings

    from jacket_cloth_ros.core.lod import LevelOfDetail
    lod = LevelOfDetail()
    lod.set_viewer((1.0, 2.0, 3.0))
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        step = lod.plan(np.array([1e200, 0.0, 0.0]), (10.0, 30.0), 0.5, 2, 1 / 120)
    assert step.level == 2


def test_default_and_latched_publishers_reach_viewer_and_wind(harness):
    """Issue 34 item 5: a publisher with default QoS (reliable, volatile: ``ros2 topic pub``)
    reaches ~/viewer and ~/wind, and a latched (transient-local) one still does, its message
    taken once though both of the viewer's subscriptions get it."""
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    default = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
    h = harness()
    _far_viewer(h, default)
    _walk(h, 0, 12)
    assert h.c.sim.lod.level == 2 and list(h.c.sim.lod.viewer) == list(FAR)
    # A latched publisher: both subscriptions match it, its message counts once.
    from jacket_cloth_ros.ros.viewer import Deliveries
    deliveries = []

    class Counted(Deliveries):
        def first(self, info):
            deliveries.append(info)
            return super().first(info)
    h.node._viewer_deliveries = Counted()
    latched = h.peer.create_publisher(PointStamped, TOPIC, VIEWER_QOS)
    h.spin_until(lambda: latched.get_subscription_count() == 2)
    latched.publish(_viewer(NEAR))
    h.spin_until(lambda: len(deliveries) == 2)
    assert h.node.received['viewer'] == 2 and h.node.refused['viewer'] == 0
    assert list(h.c.sim.lod.viewer) == list(NEAR)
    # ~/wind from a default and from a latched publisher.
    for k, qos in enumerate((default, QoSProfile(depth=1, durability=DurabilityPolicy.
                                                 TRANSIENT_LOCAL))):
        wind = h.peer.create_publisher(Vector3Stamped, '/jacket_cloth_node/wind', qos)
        h.spin_until(lambda: wind.get_subscription_count() > 0)
        msg = Vector3Stamped()
        msg.vector.x = float(k + 1)
        wind.publish(msg)
        h.spin_until(lambda: h.c.sim.params.wind == (k + 1.0, 0.0, 0.0))
    assert h.node.received['wind'] == 2 and h.node.refused['wind'] == 0


def test_a_latched_viewer_older_than_the_one_taken_is_not_applied(harness):
    # A latched publisher's old viewer can be delivered (its history) after a newer one from
    # a volatile publisher: it moved the viewer back to where it was.
    from rclpy.qos import DurabilityPolicy
    h = harness()
    by_durability = {s.qos_profile.durability: s.callback for s in h.node.subscriptions
                     if s.topic_name == TOPIC}
    latched = by_durability[DurabilityPolicy.TRANSIENT_LOCAL]
    live = by_durability[DurabilityPolicy.VOLATILE]

    def raw(point, sec):
        msg = _viewer(point)
        msg.header.stamp.sec = sec
        return serialize_message(msg)

    def info(publisher):
        return {'publisher_gid': {'data': [publisher] * 16}, 'publication_sequence_number': 1,
                'source_timestamp': publisher}
    live(raw(NEAR, 200), info(1))
    assert tuple(h.c.viewer) == NEAR
    latched(raw(FAR, 100), info(2))                 # stale: dropped
    assert tuple(h.c.viewer) == NEAR
    latched(raw(FAR, 300), info(3))                 # newer: taken
    assert tuple(h.c.viewer) == FAR
    live(raw(NEAR, 50), info(4))                    # live, whatever its stamp
    assert tuple(h.c.viewer) == NEAR
