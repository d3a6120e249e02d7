# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The jacket_cloth command, clips, and recordings that survive Ctrl-C, SIGTERM and a kill."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import DOMAIN_ID

from jacket_cloth_ros.motion.clips import ALL_CLIPS, clip_length, joint_state_content, pose
from jacket_cloth_ros.motion.messages import clip_messages
from jacket_cloth_ros.recording.reader import RecordingError, read_messages
from jacket_cloth_ros.tools.cli import main


def test_every_clip_is_continuous(skeleton):
    for clip in ALL_CLIPS:
        prev, jumps = None, 0
        for t in np.arange(0, clip_length(clip), 1 / 240):
            q, root = pose(clip, t)
            assert set(q) <= set(skeleton.joint_names)
            now = np.array(list(root[:3]))
            if prev is not None and np.linalg.norm(now - prev) > 0.1:
                jumps += 1
            prev = now
        assert jumps == (1 if clip in ('teleport', 'showcase') else 0), clip   # the 10 m jump


def test_clip_messages_are_stamped_from_the_start_and_go_on_past_a_clips_end(skeleton):
    length = clip_length('walk')
    msgs = list(clip_messages(skeleton, 'walk', 30.0, length + 1.0, 5 * 10 ** 9))
    assert len(msgs) == int(round((length + 1.0) * 30)) + 1
    for stamp, msg in msgs[:3]:
        assert stamp == msg.header.stamp.sec * 10 ** 9 + msg.header.stamp.nanosec
    assert msgs[0][0] == 5 * 10 ** 9 and msgs[1][0] - msgs[0][0] == round(1e9 / 30)
    first, again = msgs[0][1], msgs[int(round(length * 30))][1]
    assert list(first.name[:len(skeleton.joint_names)]) == list(skeleton.joint_names)
    # Issue 47 item 4: a gait goes on past its end in closed form, never back to its start.
    _, on = joint_state_content(skeleton.joint_names, 'walk', length)
    assert list(again.position) == on and again.position[-7] > first.position[-7] + 5.0


def test_motion_to_file_then_errors_are_one_line(tmp_path, capsys):
    out = tmp_path / 'walk.mcap'
    assert main(['motion', '--clip', 'walk', '--rate', '30', '-o', str(out)]) == 0
    msgs, complete = read_messages(str(out))
    assert complete and len(msgs) == 4 * 30 + 1
    assert {m.topic for m in msgs} == {'/joint_states'}
    capsys.readouterr()
    assert main(['motion', '--clip', 'walk', '-o', str(out)]) == 1       # exists, no --force
    assert main(['picture', str(out), '-o', str(tmp_path / 'p.png')]) == 1  # no markers in it
    (tmp_path / 'junk.mcap').write_bytes(b'hello')
    assert main(['picture', str(tmp_path / 'junk.mcap'), '-o', str(tmp_path / 'q.png')]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and 'exists' in err[0] and 'not an MCAP' in err[2]
    assert 'Traceback' not in ''.join(err)


def test_reading_a_non_mcap_file_is_a_recording_error(tmp_path):
    p = tmp_path / 'x.mcap'
    p.write_bytes(b'\0' * 100)
    with pytest.raises(RecordingError, match='not an MCAP'):
        read_messages(str(p))


def _run_node_and_motion(tmp_path, stop):
    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID + 1))
    path = tmp_path / 'live.mcap'
    node = subprocess.Popen([sys.executable, '-m', 'jacket_cloth_ros.ros.node', '--ros-args',
                             '-p', f'record:={path}'], env=env, stderr=subprocess.PIPE,
                            text=True)
    try:
        motion = subprocess.run(
            [sys.executable, '-m', 'jacket_cloth_ros', 'motion', '--clip', 'walk', '--rate',
             '60', '--duration', '3', '--wait', '30'], env=env, capture_output=True, timeout=60)
        assert motion.returncode == 0, motion.stderr
        node.send_signal(stop)          # inputs still queued in the node may go unrecorded
        node.wait(timeout=20)
    finally:
        if node.poll() is None:
            node.kill()
            node.wait()
    return path, node


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM])
def test_recording_is_complete_after_a_normal_shutdown(tmp_path, stop):
    path, node = _run_node_and_motion(tmp_path, stop)
    msgs, complete = read_messages(str(path))
    assert complete
    topics = {m.topic for m in msgs}
    assert {'/joint_states', '/tf', '/jacket_cloth_node/markers', '/diagnostics'} <= topics
    inputs = sum(m.topic == '/joint_states' for m in msgs)
    # Every recorded input has its /tf, but the one a signal may stop halfway through.
    assert inputs > 150 and 0 <= inputs - sum(m.topic == '/tf' for m in msgs) <= 1


def test_recording_is_readable_after_a_kill(tmp_path):
    path, node = _run_node_and_motion(tmp_path, signal.SIGKILL)
    msgs, complete = read_messages(str(path))
    assert not complete
    # Chunks are flushed about every second of stamps: most of the 3 s survive.
    assert sum(m.topic == '/tf' for m in msgs) >= 60


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM])
def test_live_motion_stops_on_a_signal_with_one_line(stop):
    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID + 3))
    motion = subprocess.Popen(
        [sys.executable, '-m', 'jacket_cloth_ros', 'motion', '--clip', 'walk', '--duration',
         '60', '--wait', '0'], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True)
    try:
        playing = motion.stderr.readline()          # signalled once the clip is playing
        assert "playing 'walk'" in playing, playing
        motion.send_signal(stop)
        out, err = motion.communicate(timeout=20)
    finally:
        if motion.poll() is None:
            motion.kill()
            motion.wait()
    assert motion.returncode == 128 + stop, err
    assert 'Traceback' not in err and err.strip().splitlines() == [
        f'jacket_cloth motion: stopped by {signal.Signals(stop).name}'], err


def test_play_publishes_a_recording_live_as_recorded_and_its_urdf(tmp_path):
    # Issue 35 item 7: a recording drives the graph where `ros2 bag play` is absent. Each
    # message keeps its names, positions and spacing of stamps; the URDF goes latched.
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.ros.cdr import JointStateReader

    recording = tmp_path / 'walk.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '1', '--rate', '30', '-o',
                 str(recording)]) == 0
    reader = JointStateReader()
    recorded = [reader.read(m.data) for m in read_messages(str(recording))[0]]
    urdf = shipped('character.urdf')
    domain = DOMAIN_ID + 12
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    peer = rclpy.create_node('play_peer', context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(peer)
    got, description = [], []
    peer.create_subscription(JointState, '/npc/joint_states', got.append, 100)
    peer.create_subscription(String, '/npc/robot_description', description.append,
                             QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    play = subprocess.Popen(
        [sys.executable, '-m', 'jacket_cloth_ros', 'play', str(recording), '--urdf', urdf,
         '--wait', '120', '--ros-args', '-r', '__ns:=/npc'],
        env=dict(os.environ, ROS_DOMAIN_ID=str(domain)), stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 300      # a limit for a hung source, not a pace
        while len(got) < len(recorded) or not description:
            assert play.poll() in (None, 0), play.communicate()[1]
            assert time.monotonic() < deadline, f'{len(got)} of {len(recorded)} heard'
            ex.spin_once(timeout_sec=0.05)
        out, err = play.communicate(timeout=60)
    finally:
        if play.poll() is None:
            play.kill()
            play.wait()
        ex.shutdown()
        peer.destroy_node()
        rclpy.shutdown(context=ctx)
    assert play.returncode == 0 and 'Traceback' not in err, err
    assert out.strip() == f'played {len(recorded)} JointState messages of {recording}'
    assert len(got) == len(recorded)
    with open(urdf, encoding='utf-8') as f:
        assert [d.data for d in description] == [f.read()]

    def stamp(m):
        return m.header.stamp.sec * 10 ** 9 + m.header.stamp.nanosec
    assert [stamp(m) - stamp(got[0]) for m in got] == [
        r.stamp_ns - recorded[0].stamp_ns for r in recorded]
    assert all(list(m.name) == list(r.name) and np.array_equal(m.position, r.position)
               for m, r in zip(got, recorded))
    assert stamp(got[0]) > recorded[0].stamp_ns + 10 ** 9      # stamped from now, not 1000 s


def test_motion_says_which_clip_joints_a_urdf_lacks_and_retargets_the_clip(tmp_path, capsys):
    # Issue 35 item 7: a clip on a skeleton that does not know its joints moved only the world;
    # issue 47 item 4: it is retargeted through the skeleton's body parts, and said so.
    from fetched import fetched

    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState
    from jacket_cloth_ros.recording.reader import read_recording
    with open(shipped('character.urdf'), encoding='utf-8') as f:
        renamed = f.read().replace('name="l_knee"', 'name="left_knee"')
    partial = tmp_path / 'partial.urdf'
    partial.write_text(renamed)
    assert main(['motion', '--clip', 'walk', '--urdf', str(partial), '--duration', '0.1',
                 '-o', str(tmp_path / 'partial.mcap')]) == 0
    assert capsys.readouterr().err.strip().startswith(
        f"jacket_cloth motion: {partial} lacks 1 of the 11 joints (l_knee) the clip 'walk' "
        'moves: retargeted through its body parts (pelvis base_link; chest chest; ')
    robot = fetched('g1_29dof_rev_1_0.urdf')
    out = tmp_path / 'robot.mcap'
    assert main(['motion', '--clip', 'walk', '--urdf', robot, '--duration', '0.5',
                 '-o', str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{robot} has none of the 11 joints the clip 'walk' moves" in err[0]
    states = [deserialize_message(m.data, JointState) for m in read_recording(str(out)).messages
              if m.topic == '/joint_states']
    knee = [s.position[list(s.name).index('left_knee_joint')] for s in states]
    assert np.ptp(knee) > 0.3                         # its legs step, not only its root
    assert [n for n in states[0].name if n.startswith('world_joint/')] == [
        f'world_joint/{v}' for v in WORLD_VARIABLES]


def test_picture_animates_a_session_beside_its_filmstrip(tmp_path, capsys):
    # Issue 35 item 7: a session seen moving, not only as stills.
    from PIL import Image
    clip, session = tmp_path / 'walk.mcap', tmp_path / 'session.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '2', '-o', str(clip)]) == 0
    assert main(['replay', str(clip), '-o', str(session)]) == 0
    markers = sum(m.type_name.endswith('MarkerArray') for m in read_messages(str(session))[0])
    capsys.readouterr()
    assert main(['picture', str(session), '-o', str(tmp_path / 'strip.png'), '--animate']) == 0
    out = capsys.readouterr().out.splitlines()
    gif = tmp_path / 'strip.gif'
    assert out[-1] == f'{gif} ({markers} frames)' and (tmp_path / 'strip.png').exists()
    with Image.open(gif) as image:
        assert image.n_frames == markers > 10
        first = np.asarray(image.convert('RGB'))
        image.seek(image.n_frames // 2)
        assert np.abs(np.asarray(image.convert('RGB')).astype(int) - first).sum() > 0  # it moves
