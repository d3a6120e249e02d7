# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s node part: the live node's CPU per JointState against the floor node.

Node processes driven at once by one JointState stream at 120 Hz (:func:`live_nodes`), the
node against ``floor_node`` with and without its kernel step (:func:`node_vs_floor`), and the
first /tf after start, warm and cold (:func:`cold_start`).
"""

import itertools
import os
import signal
import subprocess
import sys
import tempfile
import time
from typing import Iterable

from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
from .. import lab_domain
from ..proc import cpu_seconds
from .measure import RATE


def live_nodes(skeleton: Skeleton, commands: dict[str, tuple[list[str], str]], seconds: float,
               domain: int, start_limit_s: float = 30.0) -> dict[str, dict]:
    """Drive node processes at once with one JointState stream at RATE; what each cost.

    All of them take the same messages over the same wall-clock interval, so a drift in this
    machine's speed (other guests on the host) reaches each alike.

    The character's URDF is on /robot_description, latched, as robot_state_publisher offers
    it: the node does not wait out its robot_description_timeout for the shipped character.

    :param skeleton: the character the stream moves.
    :param commands: name -> (argv, the /tf topic it publishes on).
    :param seconds: how long to measure, once every process publishes.
    :param domain: the ROS domain id the run has to itself.
    :param start_limit_s: how long the processes may take to publish their first /tf.
    :returns: name -> {cpu_us_per_message, start_s (to its first /tf), answered, sent,
        latency_by_status (each diagnostics status's p99 per window), latency_us_p99 (those
        of the only status, if one), latency_us_max (its slowest input per window)}.
    """
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    from tf2_msgs.msg import TFMessage

    from jacket_cloth_ros.ros.character import LATCHED
    from jacket_cloth_ros.motion.messages import clip_messages
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=domain)
    node = rclpy.create_node('jacket_cloth_speed_driver', context=ctx)
    first_tf = {}
    tf_count = dict.fromkeys(commands, 0)
    latencies = {}                  # the diagnostics' status name -> p99 per window
    slowest = {}                    # the diagnostics' status name -> max per window

    def counter(name):
        def on_tf(raw):
            tf_count[name] += 1
            first_tf.setdefault(name, time.monotonic())
        return on_tf

    def on_diag(msg):
        for status in msg.status:
            for kv in status.values:
                if kv.key == 'latency_us_p99':
                    latencies.setdefault(status.name, []).append(float(kv.value))
                elif kv.key == 'latency_us_max':
                    slowest.setdefault(status.name, []).append(float(kv.value))
    for name, (_, topic) in commands.items():
        node.create_subscription(TFMessage, topic, counter(name), 100, raw=True)
    node.create_subscription(DiagnosticArray, '/diagnostics', on_diag, 10)
    pub = node.create_publisher(JointState, 'joint_states',
                                QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE))
    description = node.create_publisher(String, '/robot_description', LATCHED)
    description.publish(String(data=shipped_character_urdf()))
    # One walk: until every first /tf (30 s and more on a cold start) made as it is sent,
    # then the measured part made beforehand.
    walk = clip_messages(skeleton, 'walk', RATE, start_limit_s + seconds + 3.0, 10 ** 10)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)

    def send_paced(messages, until=lambda: False):
        """Publish at RATE (spin_once returns at each callback: wait out the deadline)."""
        t0 = time.monotonic()
        for j, msg in enumerate(messages):
            if until():
                return
            if pub.get_subscription_count():
                pub.publish(msg)
            while True:
                left = t0 + (j + 1) / RATE - time.monotonic()
                if left <= 0:
                    break
                ex.spin_once(timeout_sec=left)
    started = time.monotonic()
    procs = {name: subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL)
             for name, (argv, _) in commands.items()}
    try:
        send_paced((m for _, m in walk), until=lambda: len(first_tf) == len(commands) or (
            time.monotonic() - started > start_limit_s))
        late = [name for name in commands if name not in first_tf]
        if late:
            raise RuntimeError(f'{", ".join(late)}: no /tf within {start_limit_s:g} s')
        msgs = [m for _, m in itertools.islice(walk, int((seconds + 1.0) * RATE))]
        send_paced(msgs[:int(RATE)])                    # a second of warm-up
        n = len(msgs) - int(RATE)
        cpu0 = {name: cpu_seconds(p.pid) for name, p in procs.items()}
        tf0 = dict(tf_count)
        latencies.clear()
        slowest.clear()
        send_paced(msgs[int(RATE):])
        cpu1 = {name: cpu_seconds(p.pid) for name, p in procs.items()}
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
    finally:
        stop_processes(procs.values())
        ex.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    return {name: {'cpu_us_per_message': (cpu1[name] - cpu0[name]) / n * 1e6,
                   'start_s': first_tf[name] - started, 'answered': tf_count[name] - tf0[name],
                   'sent': n, 'latency_by_status': latencies,
                   # with one node on /diagnostics, its windows
                   'latency_us_p99': next(iter(latencies.values())) if len(latencies) == 1 else [],
                   'latency_us_max': next(iter(slowest.values())) if len(slowest) == 1 else []}
            for name in commands}


def live_node(skeleton: Skeleton, command: list[str], seconds: float, domain: int,
              start_limit_s: float = 30.0) -> dict:
    """One node process driven alone (live_nodes).

    :param skeleton: the character the stream moves.
    :param command: the node's argv; it publishes on /tf.
    :param seconds: how long to measure, once it publishes.
    :param domain: the ROS domain id the run has to itself.
    :param start_limit_s: how long it may take to publish its first /tf.
    """
    return live_nodes(skeleton, {'node': (command, '/tf')}, seconds, domain,
                      start_limit_s)['node']


def node_vs_floor(skeleton: Skeleton, seconds: float, kernel_us: float, record_dir: str,
                  rounds: int = 3) -> dict:
    """Measure the node's CPU per message against two floors, each measured the same way.

    - ``floor_us``: the floor node with one bare kernel step in each callback, so the kernel
      runs as it does in the node (8 ms apart, after a sleep; the issue's floor);
    - ``warm_floor_us``: the floor node without it plus the kernel's back-to-back median,
      a stricter floor no node meets (its kernel never runs warm).

    The three run at once on the same stream (each floor's /tf remapped), a few rounds:
    run one after another, this machine's drift made a floor with its kernel cost less than
    the same floor without it (host steal 9-25 % while idle). The median round is reported.
    The node's start and latency come from a run of the node alone first.

    :param skeleton: the shipped character.
    :param seconds: how long each round measures.
    :param kernel_us: the kernel's back-to-back median, us (:func:`input_vs_kernel`'s).
    :param record_dir: where the node records its session (recording on, as the issue sets).
    :param rounds: how many rounds.
    """
    domain = lab_domain('crowd')          # the crowd part runs after this one
    node_cmd = [sys.executable, '-m', 'jacket_cloth_ros.ros.node', '--ros-args',
                '-p', f'record:={os.path.join(record_dir, "speed_session.mcap")}']
    floor_cmd = [sys.executable, '-m', 'jacket_cloth_lab.floor_node']
    alone = live_node(skeleton, node_cmd, seconds, domain)
    runs = []
    for r in range(rounds):
        got = live_nodes(skeleton, {
            'node': (node_cmd, '/tf'),
            'floor': (floor_cmd + ['--kernel', '--ros-args', '-r', '/tf:=/floor_tf'],
                      '/floor_tf'),
            'bare': (floor_cmd + ['--ros-args', '-r', '/tf:=/bare_tf'], '/bare_tf'),
        }, seconds, domain + 1 + r)
        cpu, floor_us = (got[k]['cpu_us_per_message'] for k in ('node', 'floor'))
        bare_us = got['bare']['cpu_us_per_message']
        runs.append({'node_us': cpu, 'floor_us': floor_us, 'ratio': cpu / floor_us,
                     'paced_kernel_us': floor_us - bare_us, 'bare_floor_us': bare_us,
                     'warm_floor_us': bare_us + kernel_us,
                     'warm_ratio': cpu / (bare_us + kernel_us),
                     'answered': {k: v['answered'] for k, v in got.items()},
                     'sent': got['node']['sent']})
    middle = sorted(runs, key=lambda x: x['ratio'])[len(runs) // 2]
    return dict(middle, rounds=runs, kernel_us=kernel_us, node=alone,
                ratios=[x['ratio'] for x in runs], warm_ratios=[x['warm_ratio'] for x in runs],
                latency_windows=alone['latency_us_p99'],
                latency_max_windows=alone['latency_us_max'], start_s=alone['start_s'])


def cold_start(skeleton: Skeleton, seconds: float = 1.0, warmed: bool = False) -> float:
    """Time the first /tf after start with an empty numba cache: what a fresh install pays.

    :param skeleton: the character the stream moves.
    :param seconds: how long the node is driven once it publishes.
    :param warmed: whether `jacket_cloth warm` fills that cache first (what the set-up does).
    :returns: seconds from the start to the first /tf.
    """
    with tempfile.TemporaryDirectory() as cache:
        os.environ['NUMBA_CACHE_DIR'] = cache
        try:
            if warmed:
                subprocess.run([sys.executable, '-m', 'jacket_cloth_ros', 'warm'], check=True,
                               stdout=subprocess.DEVNULL)
            return live_node(skeleton, [sys.executable, '-m', 'jacket_cloth_ros.ros.node'],
                             seconds, 95, start_limit_s=300.0)['start_s']
        finally:
            del os.environ['NUMBA_CACHE_DIR']


def stop_processes(procs: Iterable[subprocess.Popen]) -> None:
    """SIGINT every process, then wait for each (10 s) and kill what is still running.

    :param procs: the processes, started by this one.
    """
    procs = list(procs)
    for p in procs:
        p.send_signal(signal.SIGINT)
    for p in procs:
        try:
            p.wait(10)
        except subprocess.TimeoutExpired:
            p.kill()
