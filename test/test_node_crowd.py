# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""jacket_cloth_crowd over real DDS in one process: each character as it would be alone."""

import contextlib
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
from geometry_msgs.msg import PointStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from jacket_cloth_ros.core.config import ConfigError, shipped
from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.recording.reader import read_recording
from jacket_cloth_ros.ros import cdr
from jacket_cloth_ros.ros.characters import crowd_slice, load_characters
from jacket_cloth_ros.ros.character import LATCHED
from jacket_cloth_ros.ros.node import JacketClothNode
from jacket_cloth_ros.ros.pipeline import SessionPipeline
from jacket_cloth_ros.ros.viewer import VIEWER_QOS
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
    parameters: {robot_description_timeout: 60.0}   # a loaded machine's discovery is slow
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


def _inputs(skeleton, clip, count, garbage=False, x=0.0, first=0):
    """Serialized JointStates of a clip at 60 Hz; with ``garbage``, bad ones among them.

    ``x`` moves the character along the world's x axis (m); ``first`` is the first input's index.
    """
    out = []
    for k in range(first, first + count):
        names, pos = joint_state_content(skeleton.joint_names, clip, k / 60)
        pos = [float(p) for p in pos]
        if x:
            pos[list(names).index('world_joint/trans_x')] += x
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


def _alone(spec, urdf, raws, viewer=None):
    """The /tf a character's own pipeline gives for these inputs, alone (and this viewer)."""
    skeleton = Skeleton(urdf)
    pipeline = SessionPipeline(skeleton, load_rig(skeleton, spec.rig), spec.values, spec.name)
    if viewer is not None:
        pipeline.set_viewer(np.array(viewer))
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
        node = JacketClothNode(crowd=True, context=ctx, parameter_overrides=[
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
        assert {f'/jacket_cloth_crowd: {n}: cloth simulation' for n in 'abc'} <= set(statuses)
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
    # Markers too, each character's at the inputs of its own output phase.
    markers = {t for t in read_recording(record).topics if t.endswith('/markers')}
    assert len(markers) == 3
    for topic in markers:
        assert ([m.data for m in read_recording(out).messages if m.topic == topic]
                == [m.data for m in read_recording(record).messages if m.topic == topic])


@pytest.mark.parametrize('count', [3, 1])
def test_a_batch_with_two_inputs_of_each_character_gives_each_input_its_own_outputs(
        tmp_path, count):
    """A backlog taken at once: each input's /tf and markers are its own, as alone and replayed.

    Two inputs of a character in one batch run as two rounds; before, both inputs' outputs
    were made after the second round, so the first input's /tf carried the second's bones.
    A crowd of one (stepped alone) too.
    """
    raws = _inputs(Skeleton(shipped_character_urdf()), 'walk', 24)
    chars, record = _recorded_crowd(
        tmp_path, f'characters:\n  - name: c\n    count: {count}\n    urdf: character.urdf\n',
        [raws[k:k + 2] for k in range(0, len(raws), 2)])
    recorded = read_recording(record).messages
    with open(shipped('character.urdf'), encoding='utf-8') as f:
        urdf = f.read()
    for c in chars:
        got = [m.data for m in recorded if m.topic == '/tf' and deserialize_message(
            m.data, TFMessage).transforms[0].child_frame_id.startswith(c.spec.name + '/')]
        assert got == _alone(c.spec, urdf, raws), c.spec.name
    out = str(tmp_path / 'replay.mcap')
    replay_crowd(record, out)
    replayed = read_recording(out).messages
    for topic in {m.topic for m in recorded if m.topic == '/tf' or m.topic.endswith('/markers')}:
        assert ([m.data for m in replayed if m.topic == topic]
                == [m.data for m in recorded if m.topic == topic]), topic


def test_a_backlog_is_taken_and_processed_in_one_wake_up(tmp_path):
    """Every queued input of every character in one batch, in order, as alone.

    One message per subscription a wake-up, and the batch a guard condition's callback after
    it, cost an executor wake-up more per tick and a wake-up per queued input (docs/crowd.md).
    """
    skeleton = Skeleton(shipped_character_urdf())
    raws = {n: _inputs(skeleton, 'walk', 3, x=x) for n, x in (('a', 0.0), ('b', 2.0))}
    with _crowd(tmp_path, 'characters:\n  - {name: a, urdf: character.urdf}\n'
                '  - {name: b, urdf: character.urdf}\n') as crowd:
        batches = []
        process = crowd.node.on_joint_states
        crowd.node.on_joint_states = lambda batch: (batches.append(
            [(c.spec.name, raw) for c, raw, _ in batch]), process(batch))
        pubs = {n: crowd.peer.create_publisher(JointState, f'/{n}/joint_states', 10)
                for n in raws}
        # A listener of the same inputs, spun apart from the crowd: once it has heard them
        # all, the writer has handed every one to the crowd's readers too (an event, where a
        # sleep was a guess).
        listener = rclpy.create_node('backlog_listener', context=crowd.ctx)
        heard = []
        for n in raws:
            listener.create_subscription(JointState, f'/{n}/joint_states', heard.append, 10,
                                         raw=True)
        alone = SingleThreadedExecutor(context=crowd.ctx)
        alone.add_node(listener)
        crowd.spin_until(lambda: all(p.get_subscription_count() == 2 for p in pubs.values()))
        for k in range(3):
            for n, p in pubs.items():
                p.publish(raws[n][k])
        _spin_until(alone, lambda: len(heard) == 6)
        alone.remove_node(listener)
        listener.destroy_node()
        crowd.spin_until(lambda: batches)
        assert len(batches) == 1
        assert sorted(batches[0]) == sorted((n, r) for n in raws for r in raws[n])
        assert all([r for m, r in batches[0] if m == n] == raws[n] for n in raws)
        assert {n: c.inputs for n, c in crowd.chars.items()} == {'a': 3, 'b': 3}
        crowd.spin_until(lambda: all(len(_tf_of(crowd.tf, n)) == 3 for n in raws))
        with open(shipped('character.urdf'), encoding='utf-8') as f:
            urdf = f.read()
        for n, c in crowd.chars.items():
            assert _tf_of(crowd.tf, n) == _alone(c.spec, urdf, raws[n]), n


def test_a_character_the_shipped_one_does_not_fit_waits_and_the_others_run(tmp_path):
    # With no robot_description yet, a character whose rig does not fit the shipped
    # character took the whole crowd down at its timeout (issue 38).
    skeleton = Skeleton(shipped_character_urdf())
    with _crowd(tmp_path, 'characters:\n  - {name: a, urdf: character.urdf}\n'
                '  - {name: b, rig: examples/mannequin_rig.yaml,\n'
                '     parameters: {robot_description_timeout: 0.05}}\n') as crowd:
        crowd.spin_until(lambda: crowd.chars['b'].fallback.is_canceled())
        crowd.send({'a': _inputs(skeleton, 'walk', 3)})
        crowd.spin_until(lambda: len(_tf_of(crowd.tf, 'a')) == 3)
        assert crowd.chars['b'].pipeline is None
        # Its diagnostics say why it runs nothing (issue 38).
        crowd.spin_until(lambda: any(
            s.name == '/jacket_cloth_crowd: b: cloth simulation'
            and 'could not be set up in its place' in s.message
            for d in crowd.diagnostics for s in d.status))


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
            ('characters: [{name: a, parameters: {wind: {x: 1.0}}}]',
             "parameters.'wind.x': not a character's parameter"),
            ('characters: [{name: a, colour: red}]', "unknown key(s) 'colour'"),
            ('characters: [{name: a, count: 0}]', 'count: 0 is outside [1, 4096]'),
            # The same frames on /tf for two characters (issue 38).
            ('characters: [{name: a, frame_prefix: x/}, {name: b, frame_prefix: x/}]',
             "characters[1].frame_prefix: characters 'a' and 'b' both have 'x/'"),
            ('characters: [{name: a}, {name: b, frame_prefix: a/}]',
             "characters[1].frame_prefix: characters 'a' and 'b' both have 'a/'"),
            ('characters: [{name: a, frame_prefix: ' + 'x' * 300 + '}]',
             'frame_prefix is 300 characters long (at most 256)'),
            ('characters: [{name: w, count: 2, frame_prefix: ""}]',
             "characters[0].frame_prefix: characters 'w_0' and 'w_1' both have ''"),
            # Its topics' names run past rcl's limit: the crowd died a second after its start,
            # every character with it (a hostile probe).
            ('characters: [{name: ' + 'a' * 201 + '}]',
             'name: 201 characters, over the 200 its topics\' names leave it'),
            ('characters: [{name: a, frame_prefix: [1, 2]}]',
             'frame_prefix: [1, 2] is not text (quote it: "[1, 2]")')):
        path.write_text(text)
        with pytest.raises(ConfigError, match='^' + str(path).replace('.', r'\.')) as e:
            load_characters(str(path))
        assert error in str(e.value) and '\n' not in str(e.value), text


def test_a_nested_group_in_a_characters_file_is_applied_as_in_a_params_file(tmp_path):
    path = tmp_path / 'nested.yaml'
    path.write_text('characters: [{name: a, fabric: down_jacket, '
                    'parameters: {fabric: {damping: 0.2}, markers_rate: 5.0}}]')
    [spec] = load_characters(str(path))
    assert spec.values.fabric.damping == 0.2 and spec.values.markers_rate == 5.0
    assert spec.values.fabric_preset == 'down_jacket'


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
    # The names docs/crowd.md gives, <name>_0 .. <name>_N-1, unpadded past 10 (issue 48).
    assert [s.name for s in specs] == [f'walker_{k}' for k in range(12)]
    assert specs[11].values.frame_prefix == 'walker_11/'
    assert specs[1].namespace == '/walker_1'
    assert len({s.namespace for s in specs}) == 12
    assert np.all([s.urdf == specs[0].urdf for s in specs])


# The crowd's ~/viewer (issue 23 item 5): one camera, each character's level by its own distance.
VIEWER_TOPIC = '/jacket_cloth_crowd/viewer'
NEAR_FAR = """
defaults:
  parameters: {diagnostics_rate: 20.0}
characters:
  - name: near                   # walks at the origin
    urdf: character.urdf
  - name: far                    # walks 100 m along x; its URDF comes after the viewer
    parameters: {robot_description_timeout: 60.0}
"""
FAR_X = 100.0


def _viewer(point, frame='world'):
    msg = PointStamped()
    msg.header.frame_id = frame
    msg.point.x, msg.point.y, msg.point.z = point
    return msg


class _Crowd:
    """A crowd node and a peer over real DDS in one process, with /tf and diagnostics heard."""

    def __init__(self, tmp_path, text, **params):
        path = tmp_path / 'crowd.yaml'
        path.write_text(text)
        self.ctx = Context()
        rclpy.init(context=self.ctx, domain_id=DOMAIN_ID)
        self.ex = SingleThreadedExecutor(context=self.ctx)
        self.node = None
        try:
            self.node = JacketClothNode(crowd=True, context=self.ctx, parameter_overrides=[
                Parameter('characters', value=str(path))] + [
                Parameter(k, value=v) for k, v in params.items()])
        except Exception:
            self.close()
            raise
        self.peer = rclpy.create_node('crowd_peer', context=self.ctx)
        self.tf, self.diagnostics = [], []
        self.peer.create_subscription(TFMessage, '/tf', self.tf.append, 1000, raw=True)
        self.peer.create_subscription(DiagnosticArray, '/diagnostics', self.diagnostics.append,
                                      1000)
        self.viewer = self.peer.create_publisher(PointStamped, VIEWER_TOPIC, VIEWER_QOS)
        self.ex.add_node(self.node)
        self.ex.add_node(self.peer)
        self.chars = {c.spec.name: c for c in self.node.characters}
        self.pubs = {}

    def spin_until(self, predicate):
        _spin_until(self.ex, predicate)

    def look_from(self, point, frame='world'):
        """Publish a viewer; returns once the node has taken (or refused) it."""
        sent = self.node.received['viewer'] + 1
        self.viewer.publish(_viewer(point, frame))
        self.spin_until(lambda: self.node.received['viewer'] == sent)

    def send(self, raws):
        """Send each character's inputs, one of each at a time (one batch), all processed."""
        for n in raws:
            if n not in self.pubs:
                self.pubs[n] = self.peer.create_publisher(JointState, f'/{n}/joint_states', 10)
        self.spin_until(lambda: all(self.pubs[n].get_subscription_count() for n in raws))
        for k in range(max(len(r) for r in raws.values())):
            want = {n: self.chars[n].inputs + (k < len(r)) for n, r in raws.items()}
            for n, r in raws.items():
                if k < len(r):
                    self.pubs[n].publish(r[k])
            self.spin_until(lambda: all(self.chars[n].inputs == want[n] for n in raws))

    def statuses(self):
        """Each character's last diagnostics values, by character name."""
        out = {}
        for m in self.diagnostics:
            for s in m.status:
                out[s.name.split(': ')[1]] = {kv.key: kv.value for kv in s.values}
        return out

    def close(self):
        self.ex.shutdown()
        if self.node is not None:
            self.node.close()
            self.node.destroy_node()
        rclpy.shutdown(context=self.ctx)


@contextlib.contextmanager
def _crowd(tmp_path, text, **params):
    crowd = _Crowd(tmp_path, text, **params)
    try:
        yield crowd
    finally:
        crowd.close()


def _tf_of(tf, name):
    return [bytes(m) for m in tf
            if deserialize_message(m, TFMessage).transforms[0].child_frame_id.startswith(
                name + '/')]


def test_one_viewer_gives_each_character_of_a_crowd_its_own_level_of_detail(tmp_path):
    """One ~/viewer near one character and 100 m from the other: the far one runs the far
    level (its /tf differs from a crowd without a viewer), the near one full detail (its /tf
    the same, byte for byte), each with its own lod_level and distance in diagnostics; the far
    one is loaded after the viewer came and gets it all the same."""
    urdf = shipped_character_urdf()
    view = (0.0, 1.0, 0.0)
    with _crowd(tmp_path, NEAR_FAR) as crowd:
        crowd.spin_until(lambda: crowd.viewer.get_subscription_count() > 0)
        crowd.look_from(view)
        assert crowd.chars['far'].pipeline is None           # not loaded yet
        crowd.peer.create_publisher(String, '/far/robot_description', LATCHED).publish(
            String(data=urdf))
        crowd.spin_until(lambda: crowd.chars['far'].pipeline is not None)
        skeleton = crowd.chars['near'].sim.skeleton
        raws = {'near': _inputs(skeleton, 'walk', 40), 'far': _inputs(skeleton, 'walk', 40,
                                                                      x=FAR_X)}
        crowd.send(raws)
        crowd.spin_until(lambda: len(crowd.tf) >= 80)
        assert [crowd.chars[n].sim.lod.level for n in ('near', 'far')] == [0, 2]
        # Diagnostics written after the last input (by it, or by the wall-time watchdog).
        crowd.spin_until(lambda: {n: s.get('inputs') for n, s in crowd.statuses().items()} ==
                         {'near': '40', 'far': '40'})
        statuses = crowd.statuses()
        assert [statuses[n]['lod_level'] for n in ('near', 'far')] == ['0', '2']
        assert 0.5 < float(statuses['near']['viewer_distance_m']) < 3.0
        assert 95.0 < float(statuses['far']['viewer_distance_m']) < 105.0
        got = {n: _tf_of(crowd.tf, n) for n in raws}
    for n, c in crowd.chars.items():
        without = _alone(c.spec, urdf, raws[n])
        assert len(got[n]) == len(without) == 40
        assert (got[n] == without) == (n == 'near'), n
        assert got[n] == _alone(c.spec, urdf, raws[n], viewer=view), n


def test_a_bad_viewer_is_refused_and_each_character_keeps_its_last(tmp_path):
    """A viewer in no character's world frame, or not finite, is refused with one throttled
    warning, the last kept by every character; one in a frame only some characters live in
    goes to those only."""
    text = NEAR_FAR.replace('    parameters: {robot_description_timeout: 60.0}\n',
                            '    urdf: character.urdf\n') + (
        '  - name: mapped                 # at the origin of another world frame\n'
        '    urdf: character.urdf\n'
        '    parameters: {world_frame: map}\n')
    view = (0.0, 1.0, 0.0)
    with _crowd(tmp_path, text) as crowd:
        node = crowd.node
        crowd.spin_until(lambda: crowd.viewer.get_subscription_count() > 0)
        crowd.look_from(view)
        crowd.look_from((FAR_X, 1.0, 0.0), 'camera')     # would make the near one far
        crowd.look_from((math.nan, 1.0, 0.0))
        assert node.refused['viewer'] == 2 and 'viewer' in node._log_times
        crowd.look_from((0.0, 50.0, 0.0), 'map')         # mapped's world only
        assert node.received['viewer'] == 4 and node.refused['viewer'] == 2
        skeleton = crowd.chars['near'].sim.skeleton
        crowd.send({'near': _inputs(skeleton, 'walk', 20),
                    'far': _inputs(skeleton, 'walk', 20, x=FAR_X),
                    'mapped': _inputs(skeleton, 'walk', 20)})
        sims = {n: c.sim for n, c in crowd.chars.items()}
        assert [list(sims[n].lod.viewer) for n in ('near', 'far')] == [list(view)] * 2
        assert list(sims['mapped'].lod.viewer) == [0.0, 50.0, 0.0]
        assert [sims[n].lod.level for n in ('near', 'far', 'mapped')] == [0, 2, 2]
        crowd.spin_until(lambda: len(crowd.tf) >= 60)


def test_a_crowd_recording_with_a_moving_viewer_replays_bit_for_bit(tmp_path):
    """The viewer moves from the near character to the far one mid-session: each swaps its
    level at the input it did live, and the recording replays to the same /tf, in order."""
    record = str(tmp_path / 'crowd.mcap')
    text = NEAR_FAR.replace('    parameters: {robot_description_timeout: 60.0}\n',
                            '    urdf: character.urdf\n')
    levels = []
    with _crowd(tmp_path, text, record=record) as crowd:
        crowd.spin_until(lambda: crowd.viewer.get_subscription_count() > 0)
        skeleton = crowd.chars['near'].sim.skeleton
        for k, view in enumerate([(0.0, 1.0, 0.0), (FAR_X, 1.0, 0.0)]):
            crowd.look_from(view)
            crowd.send({'near': _inputs(skeleton, 'walk', 30, first=30 * k),
                        'far': _inputs(skeleton, 'walk', 30, x=FAR_X, first=30 * k)})
            levels.append([crowd.chars[n].sim.lod.level for n in ('near', 'far')])
        crowd.spin_until(lambda: len(crowd.tf) >= 120)
        live = [bytes(m) for m in crowd.tf]
    assert levels == [[0, 2], [2, 0]]
    recorded = read_recording(record)
    assert [m.topic for m in recorded.messages].count(VIEWER_TOPIC) == 2
    out = str(tmp_path / 'replay.mcap')
    characters, _ = replay_crowd(record, out)
    assert [c.pipeline.sim.lod.level for c in characters.values()] == [2, 0]
    replayed = read_recording(out)
    tf = [m.data for m in recorded.messages if m.topic == '/tf']
    assert len(tf) == 120 and tf == live
    assert [m.data for m in replayed.messages if m.topic == '/tf'] == tf
    assert [m.topic for m in replayed.messages].count(VIEWER_TOPIC) == 2


def _recorded_crowd(tmp_path, characters, batches):
    """Run a recording crowd node of ``characters`` (the file's text) without DDS.

    Each batch of raw JointStates goes to every character at once. Returns (the node's
    characters, the recording's path).
    """
    path = tmp_path / 'crowd.yaml'
    path.write_text(characters)
    record = str(tmp_path / 'crowd.mcap')
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    try:
        node = JacketClothNode(crowd=True, context=ctx, parameter_overrides=[
            Parameter('characters', value=str(path)), Parameter('record', value=record)])
        for batch in batches:
            node.on_joint_states([(c, raw, {}) for raw in batch for c in node.characters])
        node.close()
        node.destroy_node()
    finally:
        rclpy.shutdown(context=ctx)
    return node.characters, record


def _outputs_per_input(tmp_path, n, inputs):
    """Feed a crowd of ``n`` (markers 20 Hz, diagnostics 4 Hz) every input of ``inputs``.

    Returns {stamp: [markers, diagnostics]} as recorded.
    """
    _, record = _recorded_crowd(
        tmp_path, 'defaults:\n  parameters: {markers_rate: 20.0, diagnostics_rate: 4.0}\n'
        f'characters:\n  - name: c\n    count: {n}\n    urdf: character.urdf\n',
        [[raw] for raw in inputs(Skeleton(shipped_character_urdf()))])
    per_input = {}          # stamp -> [markers, diagnostics]
    for m in read_recording(record).messages:
        kind = 0 if m.topic.endswith('/markers') else 1 if m.topic == '/diagnostics' else None
        if kind is not None:
            per_input.setdefault(m.log_time, [0, 0])[kind] += 1
    return per_input


def test_a_crowd_spreads_its_characters_markers_and_diagnostics_over_the_inputs(tmp_path):
    """Characters started together do not all publish markers and diagnostics on one input.

    Each is its character's periodic work: on one input's tick, a crowd's all at once made
    the inputs behind them late (docs/crowd.md). After each character's first, they spread.
    """
    n = 12
    per_input = _outputs_per_input(tmp_path, n, lambda skeleton: _inputs(skeleton, 'walk', 40))
    first, *later = sorted(per_input)
    assert per_input[first] == [n, n]                       # everyone's first, at once
    # Then markers every 3rd input (20 Hz) and diagnostics every 15th (4 Hz), spread: all n
    # on one input without the phases.
    assert max(per_input[t][0] for t in later) <= n // 2
    assert max(per_input[t][1] for t in later) <= 2
    assert sum(per_input[t][1] for t in later) >= n         # nobody skipped one


def test_a_crowd_keeps_its_output_phases_across_a_gap_in_the_inputs(tmp_path):
    """A gap longer than the periods (a backlog taken at once, a pause) keeps the spread.

    Seen live: a crowd's first batch held two inputs of each character, far apart, every
    character's markers and diagnostics fell due on the second and, counted from it, came
    on one input ever after (docs/crowd.md).
    """
    n = 12
    per_input = _outputs_per_input(tmp_path, n, lambda skeleton: (
        _inputs(skeleton, 'walk', 1) + _inputs(skeleton, 'walk', 40, first=55)))  # 0.9 s gap
    first, after_gap, *later = sorted(per_input)
    assert per_input[first] == [n, n]
    assert max(per_input[t][0] for t in later) <= n // 2
    assert max(per_input[t][1] for t in later) <= 2
    assert sum(per_input[t][1] for t in later) >= n


def test_a_crowd_builds_only_the_markers_someone_reads(tmp_path, monkeypatch):
    """Not recording, each character builds its markers only while they have a subscriber."""
    from visualization_msgs.msg import MarkerArray

    from jacket_cloth_ros.ros import messages
    built = []

    def counted(sim, *args, **kwargs):
        built.append(sim)
        return marker_array(sim, *args, **kwargs)
    marker_array = messages.marker_array
    monkeypatch.setattr(messages, 'marker_array', counted)
    text = ('defaults: {parameters: {markers_rate: 20.0}}\n'
            'characters: [{name: a, urdf: character.urdf}, {name: c, urdf: character.urdf}]\n')
    with _crowd(tmp_path, text) as crowd:
        got = []
        crowd.peer.create_subscription(MarkerArray, '/a/jacket_cloth_node/markers', got.append, 10)
        crowd.spin_until(lambda: crowd.chars['a'].markers.get_subscription_count() == 1)
        built.clear()               # each pipeline's own, loading the encoder's kernels
        skeleton = Skeleton(shipped_character_urdf())
        raws = _inputs(skeleton, 'walk', 30)
        crowd.send({'a': raws, 'c': raws})
        crowd.spin_until(lambda: len(got) >= 9)
        sims = {name: c.sim for name, c in crowd.chars.items()}
        assert built.count(sims['a']) == len(got) == 10 and sims['c'] not in built


def test_the_single_node_is_a_crowd_of_one(tmp_path):
    """jacket_cloth_node and jacket_cloth_crowd are one node class with one per-character
    path (issue 34): the single node with a character's parameters and a crowd of that one
    character record the same /tf and markers, byte for byte, for the same inputs, bad ones
    included; both step it alone (no crowd call)."""
    urdf = shipped_character_urdf()
    raws = _inputs(Skeleton(urdf), 'dodge', 30, garbage=True)
    (tmp_path / 'crowd.yaml').write_text(
        'characters: [{name: a, urdf: character.urdf, parameters: {markers_rate: 20.0}}]\n')
    ctx = Context()
    rclpy.init(context=ctx, domain_id=DOMAIN_ID)
    records = {'node': str(tmp_path / 'node.mcap'), 'crowd': str(tmp_path / 'crowd.mcap')}
    nodes = {}
    try:
        nodes['node'] = JacketClothNode(context=ctx, parameter_overrides=[
            Parameter('robot_description', value=urdf), Parameter('frame_prefix', value='a/'),
            Parameter('markers_rate', value=20.0), Parameter('record', value=records['node'])])
        nodes['crowd'] = JacketClothNode(crowd=True, context=ctx, parameter_overrides=[
            Parameter('characters', value=str(tmp_path / 'crowd.yaml')),
            Parameter('record', value=records['crowd'])])
        assert type(nodes['node']) is type(nodes['crowd'])
        for node in nodes.values():
            [c] = node.characters
            assert type(c) is type(nodes['node'].characters[0])
            for raw in raws:
                node.on_joint_states([(c, raw, {})])
            assert (c.inputs, c.pipeline.undecodable, c.pipeline.dropped) == (30, 1, 1)
            assert node.crowd.steps.calls == 0                  # stepped alone
    finally:
        for node in nodes.values():
            node.close()
            node.destroy_node()
        rclpy.shutdown(context=ctx)
    markers = {'node': '/jacket_cloth_node/markers', 'crowd': '/a/jacket_cloth_node/markers'}
    got = {}
    for name, path in records.items():
        messages = read_recording(path).messages
        got[name] = {kind: [m.data for m in messages if m.topic == topic]
                     for kind, topic in (('tf', '/tf'), ('markers', markers[name]))}
    assert len(got['node']['tf']) == 29 and len(got['node']['markers']) >= 5
    assert got['node'] == got['crowd']


def test_a_crowd_takes_a_new_name_list_object_each_message_the_steady_way():
    """rclpy's own deserialisation makes a new name list per message: the crowd still takes
    them the steady way; a list that really changes each message is never armed on (that
    cost more than the input's steps), and every character's /tf stays what it is alone."""
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import CrowdPipeline
    skeleton = Skeleton(shipped_character_urdf())
    fabrics = load_fabrics()

    def pipeline():
        return SessionPipeline(skeleton, load_rig(skeleton),
                               default_values(fabrics['tweed_jacket']), timing=False)
    crowd, alone = CrowdPipeline(1), [pipeline(), pipeline()]
    for _ in alone:
        crowd.add(pipeline())
    got, want = [], []
    for k, raw in enumerate(_inputs(skeleton, 'walk', 24)):
        msg = deserialize_message(raw, JointState)
        same = cdr.JointStateContent(_stamp(k), tuple(msg.name), np.array(msg.position))
        # The second character's list turns round every other message.
        turned = (cdr.JointStateContent(same.stamp_ns, same.name[::-1], same.position[::-1])
                  if k % 2 else same)
        inputs = [(0, same), (1, turned)]
        got += [out for _, outs in crowd.on_joint_states(inputs) for out in outs]
        want += [out for (i, m) in inputs for out in alone[i].on_joint_state(m, m.stamp_ns)[1]]
    assert got == want
    # The first character's, but for its first two (a reset, then armed); none of the second's.
    assert crowd.steps.steady_inputs == 22


def test_an_inputs_markers_asked_for_after_its_character_stepped_on_are_refused():
    """A live crowd makes an input's markers and diagnostics after every /tf went out, or at
    once when its character has another input in the batch: asked for after that input
    instead, they would describe its state silently; they are refused. Made at once, they are
    what the character alone makes."""
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import CrowdPipeline
    skeleton = Skeleton(shipped_character_urdf())
    fabrics = load_fabrics()
    values = default_values(fabrics['tweed_jacket']).with_changes({'markers_rate': 240.0})

    def pipeline():
        return SessionPipeline(skeleton, load_rig(skeleton), values, timing=False)
    for characters in (1, 2):
        crowd, alone = CrowdPipeline(1), pipeline()
        for _ in range(characters):
            crowd.add(pipeline())
        msgs = [cdr.JointStateContent(_stamp(k), tuple(skeleton.joint_names),
                                      np.zeros(len(skeleton.joint_names))) for k in range(3)]
        first, second = crowd.step_and_tf([(0, msgs[0]), (0, msgs[1])])
        want = [alone.on_joint_state(m, m.stamp_ns)[1] for m in msgs[:2]]
        assert first[1] + first[2]() == want[0] and second[1] + second[2]() == want[1]
        assert any(key == 'markers' for key, _ in second[2]())   # the same list, once made
        (_, _, later), = crowd.step_and_tf([(0, msgs[2])])
        fourth = cdr.JointStateContent(_stamp(3), msgs[2].name, msgs[2].position)
        crowd.step_and_tf([(0, fourth)])
        with pytest.raises(RuntimeError, match='took another input'):
            later()


def test_a_named_urdf_file_that_is_empty_or_not_text_is_refused_at_start(tmp_path):
    # An empty one was taken for "no URDF" and the shipped character ran in its place, with
    # no word; one that is not UTF-8 was a traceback (a hostile probe).
    (tmp_path / 'empty.urdf').write_bytes(b'')
    (tmp_path / 'latin.urdf').write_bytes(shipped_character_urdf().encode() + b'<!-- \xff -->')
    for name, error in (('empty.urdf', 'a: URDF: empty robot description'),
                        ('latin.urdf', 'not a UTF-8 text file')):
        with pytest.raises(ConfigError, match=error):
            with _crowd(tmp_path, f'characters: [{{name: a, urdf: {name}}}]'):
                pass


def test_a_set_up_file_gone_while_a_character_waits_stops_that_character_alone(
        tmp_path, skeleton):
    # Read again at its load, a fabrics file moved meanwhile raised FileNotFoundError in the
    # fallback's timer: the whole crowd died (a hostile probe).
    import shutil
    shutil.copy(shipped('fabrics.yaml'), tmp_path / 'fab.yaml')
    text = ('characters: [{name: a, urdf: character.urdf}, {name: b, fabric_file: fab.yaml, '
            'parameters: {robot_description_timeout: 0.2}}]')
    with _crowd(tmp_path, text) as crowd:
        (tmp_path / 'fab.yaml').unlink()
        crowd.spin_until(lambda: 'cannot read' in crowd.chars['b'].waiting)
        assert crowd.chars['b'].pipeline is None and len(crowd.node.crowd.pipelines) == 1
        crowd.send({'a': _inputs(skeleton, 'walk', 3)})
        crowd.spin_until(lambda: len(_tf_of(crowd.tf, 'a')) == 3)
