# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A crowd split over K node processes, as launch_scripts/jacket_cloth_crowd.launch.py starts it.

The ``launch`` package is not installed here, so the processes are started as the launch file
starts them (the same executable, the same file, slice_index of slice_count) over real DDS.
"""

import os
import signal
import subprocess
import sys
import time

import rclpy
from conftest import DOMAIN_ID
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

from jacket_cloth_ros.core.skeleton import load_shipped_character
from jacket_cloth_ros.motion.clips import joint_state_content

K = 2
NAMES = ['w_0', 'w_1', 'w_2', 'w_3', 'w_4']


def test_k_processes_each_run_their_slice_and_together_every_character_once(tmp_path):
    path = tmp_path / 'crowd.yaml'
    path.write_text('characters:\n  - name: w\n    count: 5\n    urdf: character.urdf\n')
    domain = DOMAIN_ID + 1
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    procs = [subprocess.Popen(
        [sys.executable, '-m', 'jacket_cloth_ros.ros.crowd', '--ros-args', '-r',
         f'__node:=jacket_cloth_crowd_{i}', '-p', f'characters:={path}', '-p',
         f'slice_index:={i}', '-p', f'slice_count:={K}', '-p', 'threads:=1'], env=env,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) for i in range(K)]
    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    peer = rclpy.create_node('crowd_processes_peer', context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(peer)
    frames, statuses = {}, {}

    def on_tf(msg):
        for t in msg.transforms:
            frames.setdefault(t.child_frame_id.split('/')[0], set()).add(t.header.stamp.sec)

    def on_diag(msg):
        for s in msg.status:
            statuses[s.name] = {kv.key: kv.value for kv in s.values}
    peer.create_subscription(TFMessage, '/tf', on_tf, 1000)
    peer.create_subscription(DiagnosticArray, '/diagnostics', on_diag, 100)
    pubs = {n: peer.create_publisher(JointState, f'/{n}/joint_states', 10) for n in NAMES}
    skeleton = load_shipped_character()
    try:
        deadline = time.monotonic() + 60
        while not all(p.get_subscription_count() for p in pubs.values()):
            assert time.monotonic() < deadline, 'the crowd processes did not subscribe'
            ex.spin_once(timeout_sec=0.05)
        for k in range(30):
            names, pos = joint_state_content(skeleton.joint_names, 'idle', k / 30)
            msg = JointState(name=list(names), position=[float(p) for p in pos])
            msg.header.stamp.sec, msg.header.stamp.nanosec = 200 + k // 30, k * 33_333_333
            for p in pubs.values():
                p.publish(msg)
            end = time.monotonic() + 1 / 30
            while time.monotonic() < end:
                ex.spin_once(timeout_sec=0.01)
        deadline = time.monotonic() + 20
        while len(statuses) < len(NAMES) or set(frames) != set(NAMES):
            assert time.monotonic() < deadline, (sorted(frames), sorted(statuses))
            ex.spin_once(timeout_sec=0.05)
    finally:
        for p in procs:
            p.send_signal(signal.SIGINT)
        logs = [p.communicate(timeout=20)[0] for p in procs]
        ex.shutdown()
        peer.destroy_node()
        rclpy.shutdown(context=ctx)
    # Every character answered, each from exactly one process: 2 and 3 of the 5.
    assert set(frames) == set(NAMES)
    # Each status named by its process and its character: /jacket_cloth_crowd_<i>: <name>: ...
    owners = {s.split(': ')[1]: s.split(': ')[0] for s in statuses}
    assert set(owners) == set(NAMES)
    assert list(owners.values()).count('/jacket_cloth_crowd_0') == 2
    assert all(int(values['inputs']) > 0 for values in statuses.values())
    assert '2 of 5 characters (slice 0 of 2)' in logs[0], logs[0]
    assert '3 of 5 characters (slice 1 of 2)' in logs[1], logs[1]
    assert all(p.returncode == 0 for p in procs)


def test_the_launch_file_starts_k_processes_each_with_its_slice(monkeypatch):
    # Run the launch file's own process list with stand-ins for the launch packages.
    import importlib.util
    import types

    class Config:
        def __init__(self, name):
            self.name = name

        def perform(self, context):
            return context[self.name]
    fakes = {'launch': types.ModuleType('launch'),
             'launch.actions': types.ModuleType('launch.actions'),
             'launch.substitutions': types.ModuleType('launch.substitutions'),
             'launch_ros': types.ModuleType('launch_ros'),
             'launch_ros.actions': types.ModuleType('launch_ros.actions')}
    fakes['launch'].LaunchDescription = list
    fakes['launch.actions'].DeclareLaunchArgument = lambda *a, **k: None
    fakes['launch.actions'].OpaqueFunction = lambda function: function
    fakes['launch.substitutions'].LaunchConfiguration = Config
    fakes['launch_ros.actions'].Node = lambda **k: k
    for name, module in fakes.items():
        monkeypatch.setitem(sys.modules, name, module)
    here = os.path.dirname(os.path.abspath(__file__))
    spec = importlib.util.spec_from_file_location('crowd_launch', os.path.join(
        here, '..', 'launch_scripts', 'jacket_cloth_crowd.launch.py'))
    launch = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(launch)
    make = launch.generate_launch_description()[-1]
    context = {'characters': 'crowd.yaml', 'processes': '4', 'threads': '2', 'first': '0',
               'count': ''}
    nodes = make(context)
    assert [n['parameters'][0]['slice_index'] for n in nodes] == [0, 1, 2, 3]
    assert {n['parameters'][0]['slice_count'] for n in nodes} == {4}
    assert len({n['name'] for n in nodes}) == 4
    # On a second machine: processes 2 and 3 of the same 4.
    nodes = make(dict(context, first='2', count='2'))
    assert [n['parameters'][0]['slice_index'] for n in nodes] == [2, 3]


def test_a_bad_characters_file_stops_the_crowd_with_one_line(tmp_path):
    path = tmp_path / 'crowd.yaml'
    path.write_text('characters: [{name: a, fabric: silk}]')
    run = subprocess.run([sys.executable, '-m', 'jacket_cloth_ros.ros.crowd', '--ros-args',
                          '-p', f'characters:={path}'], capture_output=True, text=True,
                         timeout=120, env=dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID + 2)))
    assert run.returncode == 1 and 'Traceback' not in run.stderr, run.stderr
    assert run.stderr.strip().splitlines()[-1].startswith(
        f"jacket_cloth_crowd: {path}.characters[0].fabric: 'silk' is not a preset")
