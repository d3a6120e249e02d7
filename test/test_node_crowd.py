# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""jacket_cloth_crowd over real DDS in one process: each character as it would be alone."""

import math
import time

import numpy as np
import pytest
import rclpy
from conftest import DOMAIN_ID
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message, serialize_message
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from jacket_cloth_ros.core.config import ConfigError, shipped
from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.recording.reader import read_recording
from jacket_cloth_ros.ros import cdr
from jacket_cloth_ros.ros.characters import crowd_slice, load_characters
from jacket_cloth_ros.ros.crowd import JacketCrowdNode
from jacket_cloth_ros.ros.node import LATCHED
from jacket_cloth_ros.ros.pipeline import SessionPipeline
from jacket_cloth_ros.tools.crowd_replay import replay_crowd

CROWD = """
defaults:
  parameters: {markers_rate: 20.0}
characters:
  - name: a
    urdf: character.urdf
  - name: b                      # its URDF from /b/robot_description, as from r_s_p
    rig: examples/mannequin_rig.yaml
    fabric: down_jacket
  - name: c                      # the one that gets garbage
    urdf: character.urdf
    parameters: {wind: [3.0, 0.0, 0.0]}
"""


def _spin_until(ex, predicate, timeout=30.0):
    deadline = time.monotonic() + timeout
    while not predicate():
        assert time.monotonic() < deadline, 'timed out'
        ex.spin_once(timeout_sec=0.02)


def _stamp(k):
    return 100 * 10 ** 9 + int(round(k / 60 * 1e9))


def _inputs(skeleton, clip, count, garbage=False):
    """Serialized JointStates of a clip at 60 Hz; with ``garbage``, bad ones among them."""
    out = []
    for k in range(count):
        names, pos = joint_state_content(skeleton.joint_names, clip, k / 60)
        pos = [float(p) for p in pos]
        if garbage and k == 5:
            out.append(b'\x00\x01\x00\x00\x07')                  # does not decode
        if garbage and k == 8:
            pos[0] = math.nan                                     # refused
        if garbage and k == 12:
            i = list(names).index('world_joint/trans_x')          # a teleport: a reset
            pos[i] += 20.0
        msg = JointState(name=list(names), position=pos)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(_stamp(k), 10 ** 9)
        out.append(serialize_message(msg))
    return out


def _alone(spec, urdf, raws):
    """The /tf a character's own pipeline gives for these inputs, alone."""
    skeleton = Skeleton(urdf)
    pipeline = SessionPipeline(skeleton, load_rig(skeleton, spec.rig),
                               load_fabrics(spec.fabric_file), spec.values, spec.name)
    reader = cdr.JointStateReader()
    tf = []
    for raw in raws:
        try:
            msg = reader.read(raw)
        except cdr.DECODE_ERRORS:
            continue
        tf += [data for key, data in pipeline.on_joint_state(msg, msg.stamp_ns)[1]
               if key == 'tf']
    return tf


def test_each_character_of_a_crowd_gets_the_tf_it_gets_alone_and_replays_bit_for_bit(
        tmp_path):
    path = tmp_path / 'crowd.yaml'
    path.write_text(CROWD)
    record = str(tmp_path / 'crowd.mcap')
    with open(shipped('character.urdf'), encoding='utf-8') as f:
        urdf = f.read()
    with open(shipped('examples/mannequin.urdf'), encoding='utf-8') as f:
        mannequin = f.read()
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    ex = SingleThreadedExecutor(context=ctx)
    node = None
    try:
        node = JacketCrowdNode(context=ctx, parameter_overrides=[
            Parameter('characters', value=str(path)), Parameter('record', value=record)])
        peer = rclpy.create_node('crowd_peer', context=ctx)
        peer.create_publisher(String, '/b/robot_description', LATCHED).publish(
            String(data=mannequin))
        tf, diagnostics = [], []
        peer.create_subscription(TFMessage, '/tf', tf.append, 1000, raw=True)
        peer.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 100)
        ex.add_node(node)
        ex.add_node(peer)
        chars = {c.spec.name: c for c in node.characters}
        _spin_until(ex, lambda: all(c.pipeline is not None for c in chars.values()))
        assert 'Hips' in chars['b'].sim.skeleton.link_names        # the topic's, not shipped
        pubs = {n: peer.create_publisher(JointState, f'/{n}/joint_states', 10) for n in chars}
        _spin_until(ex, lambda: all(p.get_subscription_count() for p in pubs.values()))
        raws = {'a': _inputs(chars['a'].sim.skeleton, 'walk', 30),
                'b': _inputs(chars['b'].sim.skeleton, 'run', 30),
                'c': _inputs(chars['c'].sim.skeleton, 'dodge', 30, garbage=True)}
        taken = {n: 0 for n in chars}

        def done(n):
            return chars[n].inputs + chars[n].pipeline.undecodable
        for k in range(32):
            for n, msgs in raws.items():        # all three at once: one batch, one call
                if k < len(msgs):
                    pubs[n].publish(msgs[k])
                    taken[n] += 1
            _spin_until(ex, lambda: all(done(n) == taken[n] for n in chars))
        _spin_until(ex, lambda: len(tf) >= sum(c.pipeline.inputs - c.pipeline.dropped
                                               for c in chars.values()))
        # The garbage stayed with c: one undecodable, one refused, and its own resets (the
        # first sample, the teleport away and the one back).
        assert chars['c'].pipeline.undecodable == 1 and chars['c'].pipeline.dropped == 1
        assert chars['c'].sim.resets == 3
        for n in 'ab':
            assert chars[n].pipeline.undecodable == 0 and chars[n].pipeline.dropped == 0
            assert chars[n].sim.resets == 1
        # Inputs that arrived together were stepped together: fewer calls than inputs.
        assert node.crowd.steps.calls < sum(c.inputs for c in chars.values()) * 0.7
        # Each character's /tf, byte for byte, is what its own pipeline gives alone.
        got = {n: [bytes(m) for m in tf if deserialize_message(m, TFMessage).transforms[0]
                   .child_frame_id.startswith(n + '/')] for n in chars}
        for n, c in chars.items():
            alone = _alone(c.spec, urdf if n != 'b' else mannequin, raws[n])
            assert len(alone) == len(got[n]) > 20
            assert got[n] == alone, n
        statuses = {s.name: s for m in diagnostics for s in m.status}
        assert {'a: cloth simulation', 'b: cloth simulation', 'c: cloth simulation'} <= set(
            statuses)
    finally:
        ex.shutdown()
        if node is not None:
            node.close()
            node.destroy_node()
        rclpy.shutdown(context=ctx)
    # The whole crowd's recording replays to the same /tf, byte for byte, in the same order.
    out = str(tmp_path / 'replay.mcap')
    characters, _ = replay_crowd(record, out)
    assert sorted(c.name for c in characters.values()) == ['a', 'b', 'c']
    recorded = [m.data for m in read_recording(record).messages if m.topic == '/tf']
    replayed = [m.data for m in read_recording(out).messages if m.topic == '/tf']
    assert len(recorded) == len(tf) and replayed == recorded
    assert [bytes(m) for m in tf] == [bytes(m) for m in recorded]


def test_a_characters_file_is_validated_with_one_line(tmp_path):
    path = tmp_path / 'bad.yaml'
    for text, error in (
            ('characters: []', 'expected at least one character'),
            ('characters: [{name: 1x}]', "characters[0].name: '1x' is not a ROS name"),
            ('characters: [{name: a}, {name: a}]', "characters[1].name: 'a' is there twice"),
            ('characters: [{name: a, fabric: silk}]', "fabric: 'silk' is not a preset"),
            ('characters: [{name: a, urdf: nowhere.urdf}]', "urdf: no file 'nowhere.urdf'"),
            ('characters: [{name: a, parameters: {sim_rate: 5.0}}]',
             'parameters.sim_rate: 5.0 is outside [10.0, 4000.0]'),
            ('characters: [{name: a, parameters: {record: x.mcap}}]',
             "parameters.'record': not a character's parameter"),
            ('characters: [{name: a, colour: red}]', "unknown key(s) 'colour'"),
            ('characters: [{name: a, count: 0}]', 'count: 0 is outside [1, 4096]')):
        path.write_text(text)
        with pytest.raises(ConfigError, match='^' + str(path).replace('.', r'\.')) as e:
            load_characters(str(path))
        assert error in str(e.value) and '\n' not in str(e.value), text


def test_slices_of_a_crowd_cover_every_character_once():
    names = [f'n{k}' for k in range(10)]
    for count in (1, 2, 3, 4, 10, 16):
        parts = [crowd_slice(names, i, count) for i in range(count)]
        assert sum(parts, []) == names
        sizes = [len(p) for p in parts]
        assert max(sizes) - min(sizes) <= 1
    with pytest.raises(ConfigError, match='slice 2 of 2'):
        crowd_slice(names, 2, 2)


def test_copies_are_characters_of_their_own(tmp_path):
    path = tmp_path / 'crowd.yaml'
    path.write_text('characters: [{name: walker, count: 12, urdf: character.urdf}]')
    specs = load_characters(str(path))
    assert [s.name for s in specs][:3] == ['walker_00', 'walker_01', 'walker_02']
    assert specs[11].values['frame_prefix'] == 'walker_11/'
    assert len({s.namespace for s in specs}) == 12
    assert np.all([s.urdf == specs[0].urdf for s in specs])
