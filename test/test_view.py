# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A view that opens itself: the world transform on /tf, the shipped RViz config and Foxglove
layout name what the node publishes."""

import json
import os

import numpy as np
import pytest
import yaml
from rclpy.serialization import deserialize_message
from tf2_msgs.msg import TFMessage

from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.transforms import quat_to_matrix
from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.ros.cdr import JointStateReader, joint_state
from jacket_cloth_ros.ros.parameters import NODE_PARAMETERS
from jacket_cloth_ros.ros.values import default_values
from jacket_cloth_ros.ros.pipeline import SessionPipeline

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VIEW = os.path.join(ROOT, 'config', 'view')


def _tf_messages(skeleton, rig, rate=60, **values):
    fabrics = load_fabrics()
    pipe = SessionPipeline(skeleton, rig,
                           default_values(fabrics['tweed_jacket']).with_changes(values))
    reader, sent = JointStateReader(), []
    for k in range(40):                 # the run clip moves the character through the world
        names, pos = joint_state_content(skeleton.joint_names, 'run', k / rate)
        content = reader.read(joint_state(10**10 + k * 10**9 // rate, names, pos))
        _, outputs = pipe.on_joint_state(content, content.stamp_ns)
        sent.append(([deserialize_message(data, TFMessage) for key, data in outputs
                      if key == 'tf'], dict(zip(names, pos))))
    return pipe, sent


def test_publish_world_tf_puts_the_root_in_the_world_frame(skeleton, rig):
    _, without = _tf_messages(skeleton, rig)
    assert all(len(tfs) == 1 for tfs, _ in without)             # off by default
    # At 50 Hz the inputs fall between 120 Hz steps: the transform is the input's own pose,
    # as robot_state_publisher's links are, not the last step's.
    pipe, sent = _tf_messages(skeleton, rig, rate=50, publish_world_tf=True, world_frame='map')
    for tfs, values in sent[1:]:
        world = tfs[1].transforms[0]
        assert (world.header.frame_id, world.child_frame_id) == ('map', skeleton.link_names[0])
        assert world.header.stamp == tfs[0].transforms[0].header.stamp
        t, q = world.transform.translation, world.transform.rotation
        assert [t.x, t.y, t.z] == pytest.approx(
            [values[f'world_joint/trans_{a}'] for a in 'xyz'], abs=1e-12)
        given = [values[f'world_joint/rot_{a}'] for a in 'xyzw']
        assert np.allclose(quat_to_matrix([q.x, q.y, q.z, q.w]), quat_to_matrix(given),
                           atol=1e-9)
    assert abs(values['world_joint/trans_x']) + abs(values['world_joint/trans_y']) > 0.5


def test_the_rviz_config_shows_the_node_topics_in_the_world_frame():
    with open(os.path.join(VIEW, 'jacket_cloth.rviz'), encoding='utf-8') as f:
        config = yaml.safe_load(f)['Visualization Manager']
    displays = {d['Class']: d for d in config['Displays']}
    assert displays['rviz_default_plugins/MarkerArray']['Topic']['Value'] == \
        '/jacket_cloth_node/markers'
    assert displays['rviz_default_plugins/RobotModel']['Description Topic']['Value'] == \
        'robot_description'
    # The jacket and hood are what a user looks at: the bones' axes are one tick away.
    assert displays['rviz_default_plugins/TF']['Enabled'] is False
    assert displays['rviz_default_plugins/MarkerArray']['Enabled'] is True
    assert config['Global Options']['Fixed Frame'] == NODE_PARAMETERS['world_frame'][1]


def test_the_foxglove_layout_shows_the_markers_and_diagnostics():
    with open(os.path.join(VIEW, 'foxglove_layout.json'), encoding='utf-8') as f:
        layout = json.load(f)
    panels = layout['configById']
    three_d = panels['3D!jacket']
    assert three_d['topics']['/jacket_cloth_node/markers']['visible']
    assert three_d['transforms']['axisScale'] <= 0.05     # the bones' axes do not hide the jacket
    assert any(p.startswith('DiagnosticSummary!') for p in panels)

    def named(node):
        return [node] if isinstance(node, str) else named(node['first']) + named(node['second'])
    assert sorted(named(layout['layout'])) == sorted(panels)      # every panel is laid out


def test_the_view_launch_uses_the_installed_view_config():
    import ast
    path = os.path.join(ROOT, 'launch_scripts', 'jacket_cloth_view.launch.py')
    with open(path, encoding='utf-8') as f:
        text = f.read()
    ast.parse(text)
    assert "'view', 'jacket_cloth.rviz'" in text and "'publish_world_tf': True" in text
    with open(os.path.join(ROOT, 'setup.py'), encoding='utf-8') as f:
        assert "glob('config/view/*')" in f.read()


def test_a_session_with_the_world_transform_analyses_as_matching_its_recording(tmp_path):
    # Two /tf per input: analyze compares each recorded /tf with its re-simulated one.
    from jacket_cloth_ros.tools.cli import main
    clip, out = tmp_path / 'clip.mcap', tmp_path / 'replay.mcap'
    assert main(['motion', '--clip', 'run', '--duration', '1', '-o', str(clip)]) == 0
    assert main(['replay', str(clip), '-o', str(out), '-p', 'publish_world_tf:=true']) == 0
    assert main(['analyze', str(out), '--out', str(tmp_path / 'report')]) == 0
    report = json.loads((tmp_path / 'report' / 'report.json').read_text())
    session = report['sessions'][0] if 'sessions' in report else report
    assert session['replay_matches_recording'] is True
    assert session['recorded_tf_compared'] == 2 * session['frames']


def _recorded_topics_and_frames(tmp_path, *params):
    """A session as the node records it (a replay of the walk clip): its topics and frames."""
    from jacket_cloth_ros.recording.reader import read_messages
    from jacket_cloth_ros.tools.cli import main
    clip, out = tmp_path / 'clip.mcap', tmp_path / 'session.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '1', '-o', str(clip)]) == 0
    extra = [a for p in params for a in ('-p', p)]
    assert main(['replay', str(clip), '-o', str(out), '--force', *extra]) == 0
    msgs, complete = read_messages(str(out))
    assert complete
    frames = set()
    for m in msgs:
        if m.topic == '/tf':
            for t in deserialize_message(m.data, TFMessage).transforms:
                frames.update((t.header.frame_id, t.child_frame_id))
    return {m.topic for m in msgs}, frames


def test_every_topic_and_frame_the_foxglove_layout_names_is_in_a_recording(tmp_path):
    # The layout is for a recording (make demo's): it names only what one holds.
    with open(os.path.join(VIEW, 'foxglove_layout.json'), encoding='utf-8') as f:
        panels = json.load(f)['configById']
    topics, frames = _recorded_topics_and_frames(tmp_path)
    three_d = panels['3D!jacket']
    named_topics = set(three_d['topics']) | {
        p['topicPath'].split('.')[0] for p in panels.values() if 'topicPath' in p}
    assert named_topics and named_topics <= topics, named_topics - topics
    named_frames = {three_d['followTf']} | {
        layer['frameId'] for layer in three_d['layers'].values() if 'frameId' in layer}
    assert named_frames <= frames, named_frames - frames


def test_the_rviz_config_names_what_the_view_launchs_node_records(tmp_path):
    # The view launch runs the node with publish_world_tf: RViz's fixed frame comes from it;
    # the skeleton's description is robot_state_publisher's, not the node's.
    with open(os.path.join(VIEW, 'jacket_cloth.rviz'), encoding='utf-8') as f:
        config = yaml.safe_load(f)['Visualization Manager']
    topics, frames = _recorded_topics_and_frames(tmp_path, 'publish_world_tf:=true')
    markers = [d['Topic']['Value'] for d in config['Displays']
               if d['Class'] == 'rviz_default_plugins/MarkerArray']
    assert markers and set(markers) <= topics
    assert config['Global Options']['Fixed Frame'] in frames
