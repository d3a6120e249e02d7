# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s endurance part: the node's callback with recording on, over minutes."""

import os
import time

import numpy as np

from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
from .. import lab_domain
from .measure import RATE


def endurance(skeleton: Skeleton, simulated_s: float, folder: str,
              window_s: float = 60.0) -> dict:
    """Simulate motion through the node's JointState callback with recording on.

    The real JacketClothNode in this process, fed serialized JointState at 120 Hz stamps as
    fast as it takes them (DDS is skipped: nothing can be lost on the way).

    :param skeleton: the character the inputs move.
    :param simulated_s: how much motion, seconds.
    :param folder: where the recording is written.
    :param window_s: the simulated seconds each window of figures covers.
    :returns: resident memory and step cost per window and the recording's input and output
        counts.
    """
    import rclpy
    from rclpy.parameter import Parameter
    from rclpy.serialization import serialize_message

    from jacket_cloth_ros.recording.reader import count_messages
    from jacket_cloth_ros.ros.node import JacketClothNode
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.motion.messages import joint_state_message
    path = os.path.join(folder, 'endurance.mcap')
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=lab_domain('endurance'))
    urdf = shipped_character_urdf()
    node = JacketClothNode(context=ctx, parameter_overrides=[
        Parameter('record', value=path), Parameter('robot_description', value=urdf)])
    character = node.characters[0]
    windows = []
    n = int(simulated_s * RATE)
    per_window = int(window_s * RATE)
    costs = []
    try:
        for k in range(n):                 # the gait repeats; the walker goes on
            t = k / RATE
            names, pos = joint_state_content(skeleton.joint_names, 'walk', t)
            raw = serialize_message(
                joint_state_message(names, pos, 10 ** 10 + int(round(t * 1e9))))
            t0 = time.thread_time_ns()
            node.on_joint_states([(character, raw, {})])
            costs.append(time.thread_time_ns() - t0)
            if (k + 1) % per_window == 0:
                windows.append({'simulated_s': (k + 1) / RATE, 'rss_mb': _rss_mb(),
                                'input_us_median': float(np.median(costs)) * 1e-3})
                costs = []
    finally:
        node.close()
        node.destroy_node()
        rclpy.shutdown(context=ctx)
    counts, complete = count_messages(path)
    os.remove(path)
    return {'windows': windows, 'inputs': counts.get('/joint_states', 0),
            'tf': counts.get('/tf', 0), 'complete': complete}


def _rss_mb():
    with open('/proc/self/status', encoding='ascii') as f:
        for line in f:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')
