# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Two characters side by side under two namespaces, over real DDS in one process."""

import contextlib
import time

import rclpy
from conftest import DOMAIN_ID
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage
from diagnostic_msgs.msg import DiagnosticArray
from visualization_msgs.msg import MarkerArray

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.skeleton import shipped_character_urdf
from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.recording.reader import read_messages
from jacket_cloth_ros.ros.character import LATCHED
from jacket_cloth_ros.ros.node import JacketClothNode


def _spin_until(ex, predicate, timeout=20.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, 'timed out'
        ex.spin_once(timeout_sec=0.02)


@contextlib.contextmanager
def _graph():
    """Yield a context of our domain, its executor and a dict for its nodes; all shut after."""
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    ex = SingleThreadedExecutor(context=ctx)
    nodes = {}
    try:
        yield ctx, ex, nodes
    finally:
        ex.shutdown()
        for node in nodes.values():
            node.close()
            node.destroy_node()
        rclpy.shutdown(context=ctx)


def _listener(ctx, ex, nodes):
    """A peer hearing /tf, /diagnostics and each node's markers, spun with the nodes.

    Returns (peer, /tf, markers by namespace, /diagnostics).
    """
    peer = rclpy.create_node('namespaces_peer', context=ctx)
    tf, markers, diagnostics = [], {ns: [] for ns in nodes}, []
    peer.create_subscription(TFMessage, '/tf', tf.append, 100)
    peer.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 100)
    for ns in nodes:
        peer.create_subscription(MarkerArray, f'/{ns}/jacket_cloth_node/markers',
                                 markers[ns].append, 10)
    for node in (*nodes.values(), peer):
        ex.add_node(node)
    return peer, tf, markers, diagnostics


def _walk_each(ex, peer, chars, inputs):
    """Send each namespace's character ``inputs`` walk inputs at 30 Hz, each one taken."""
    pubs = {ns: peer.create_publisher(JointState, f'/{ns}/joint_states', 10) for ns in chars}
    _spin_until(ex, lambda: all(p.get_subscription_count() > 0 for p in pubs.values()))
    for k in range(inputs):
        for ns, c in chars.items():
            names, pos = joint_state_content(c.sim.skeleton.joint_names, 'walk', k / 30)
            msg = JointState(name=list(names), position=[float(p) for p in pos])
            msg.header.stamp.sec, msg.header.stamp.nanosec = 100, int(k / 30 * 1e9)
            before = c.inputs
            pubs[ns].publish(msg)
            _spin_until(ex, lambda: c.inputs > before)


def test_two_namespaced_characters_each_hear_their_own_description_and_joint_states():
    # Each namespace has its own robot_state_publisher-style latched description (the shipped
    # character under /npc1, the mannequin example with other link names under /npc2); the
    # bones of both go to the one /tf, kept apart by frame_prefix.
    from rclpy.parameter import Parameter
    with open(shipped('examples/mannequin.urdf'), encoding='utf-8') as f:
        mannequin = f.read()
    with _graph() as (ctx, ex, nodes):
        nodes.update({
            'npc1': JacketClothNode(context=ctx, namespace='/npc1', parameter_overrides=[
                Parameter('frame_prefix', value='npc1/'),
                Parameter('robot_description_timeout', value=30.0)]),
            'npc2': JacketClothNode(context=ctx, namespace='/npc2', parameter_overrides=[
                Parameter('frame_prefix', value='npc2/'),
                Parameter('rig_file', value=shipped('examples/mannequin_rig.yaml')),
                Parameter('robot_description_timeout', value=30.0)])})
        peer, tf, markers, _ = _listener(ctx, ex, nodes)
        for ns, urdf in (('npc1', shipped_character_urdf()), ('npc2', mannequin)):
            peer.create_publisher(String, f'/{ns}/robot_description', LATCHED).publish(
                String(data=urdf))
        chars = {ns: node.characters[0] for ns, node in nodes.items()}     # one each
        _spin_until(ex, lambda: all(c.sim is not None for c in chars.values()))
        assert chars['npc1'].sim.skeleton.link_names[0] == 'base_link'
        assert 'Hips' in chars['npc2'].sim.skeleton.link_names        # the mannequin's own
        _walk_each(ex, peer, chars, 6)
        _spin_until(ex, lambda: all(markers.values()) and len(tf) >= 12)
        frames = {t.child_frame_id.split('/')[0] for m in tf for t in m.transforms}
        assert frames == {'npc1', 'npc2'}
        for ns, c in chars.items():
            assert c.inputs == 6 and c.sim.resets == 1
            links = {f'{ns}/{link}' for link in c.sim.skeleton.link_names}
            assert {t.header.frame_id for m in tf for t in m.transforms
                    if t.child_frame_id.startswith(ns)} <= links


def test_two_characters_prefixed_as_robot_state_publisher_prefixes_are_two_trees(tmp_path):
    """Issue 34 item 2: one skeleton under /npc1 and /npc2, frame_prefix npc1/ and npc2/.

    Each node's /tf names only its own prefixed frames, parents included (as
    robot_state_publisher with the same prefix publishes the links), so the two jackets hang
    from two skeletons; world_frame, the world both stand in, is the one frame they share. Its
    markers are in its prefixed root, and its diagnostics are named by its node. npc1's
    recording replays to the same frames and the same diagnostics name.
    """
    from rclpy.parameter import Parameter
    from rclpy.serialization import deserialize_message
    from jacket_cloth_ros.tools.session import load_session, run_session
    record = str(tmp_path / 'npc1.mcap')
    with _graph() as (ctx, ex, nodes):
        for ns in ('npc1', 'npc2'):
            nodes[ns] = JacketClothNode(context=ctx, namespace='/' + ns, parameter_overrides=[
                Parameter('frame_prefix', value=ns + '/'),
                Parameter('robot_description', value=shipped_character_urdf()),
                Parameter('publish_world_tf', value=True),
                Parameter('diagnostics_rate', value=10.0),
                Parameter('record', value=record if ns == 'npc1' else '')])
        peer, tf, markers, diagnostics = _listener(ctx, ex, nodes)
        chars = {ns: node.characters[0] for ns, node in nodes.items()}
        _walk_each(ex, peer, chars, 6)
        _spin_until(ex, lambda: all(markers.values()) and len(tf) >= 24)   # bones, world
        links = chars['npc1'].sim.skeleton.link_names
        trees = {ns: set() for ns in nodes}
        for t in (t for m in tf for t in m.transforms):
            ns = t.child_frame_id.split('/')[0]
            assert ns in nodes, t.child_frame_id
            if t.header.frame_id == 'world':        # the world both stand in, to their roots
                assert t.child_frame_id == f'{ns}/{links[0]}'
            else:
                assert t.header.frame_id.startswith(ns + '/'), (t.header.frame_id, ns)
                trees[ns].add(t.header.frame_id)
            trees[ns].add(t.child_frame_id)
        assert not trees['npc1'] & trees['npc2']
        for ns in nodes:
            # Bones under the prefixed links: the skeleton's root has the cloth bones.
            assert f'{ns}/{links[0]}' in trees[ns] and f'{ns}/jacket_r00_c00' in trees[ns]
            assert {m.header.frame_id for a in markers[ns] for m in a.markers} == {
                f'{ns}/{links[0]}'}
        # Unique names: each node's status is its own (the same name made them one row).
        owners = {f'/{ns}/jacket_cloth_node: cloth simulation' for ns in nodes}
        _spin_until(ex, lambda: len({s.name for m in diagnostics for s in m.status}) >= 2)
        assert {s.name for m in diagnostics for s in m.status} == owners
    session = load_session(record)
    recorded = [m.data for m in read_messages(session.recording.path)[0] if m.topic == '/tf']
    replayed, diagnostics = [], []
    run_session(session, sink=lambda key, data, stamp: (
        replayed if key == 'tf' else diagnostics if key == 'diagnostics' else []).append(data))
    assert len(recorded) == 12 and replayed == recorded
    assert {s.name for raw in diagnostics for s in deserialize_message(
        raw, DiagnosticArray).status} == {'/npc1/jacket_cloth_node: cloth simulation'}
