# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s replay part: simulated seconds per second of replay, by session length."""

import os
from typing import Sequence

from jacket_cloth_ros.core.skeleton import Skeleton
from .kernel import limit_steps
from .measure import RATE, beside_kernel


def replay_scaling(skeleton: Skeleton, lengths: Sequence[float], folder: str) -> list[dict]:
    """Replay throughput (simulated s per s) for sessions of each length.

    Each replay is timed between two rounds of the bare kernel on the walk's states, whose
    median (``kernel_ns``) sets that replay's kernel-only limit: the kernel's speed here has
    phases seconds long, so a limit timed elsewhere in the run can belong to another phase.

    :param skeleton: the character the sessions move.
    :param lengths: the sessions' lengths, seconds.
    :param folder: where the sessions and replays are written.
    :returns: per session: ``session_s``, ``replay_s``, ``realtime_x`` and ``kernel_ns``.
    """
    from rclpy.serialization import serialize_message

    from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
    from jacket_cloth_ros.motion.messages import clip_messages
    from jacket_cloth_ros.tools.replay import replay
    from jacket_cloth_ros.tools.session import load_session
    steps = limit_steps(skeleton)
    rows = []
    for length in lengths:
        src = os.path.join(folder, f'clip_{length:g}.mcap')
        rec = SessionRecorder(src)
        rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState',
                      qos_profile_yaml(reliable=False))
        for stamp, msg in clip_messages(skeleton, 'walk', 60.0, length, 10 ** 10):
            rec.write('/joint_states', serialize_message(msg), stamp)
        rec.close()
        out = os.path.join(folder, f'replay_{length:g}.mcap')
        session = load_session(src)
        (_, took), kernel_ns = beside_kernel(steps, lambda: replay(session, out))
        rows.append({'session_s': length, 'replay_s': took, 'realtime_x': length / took,
                     'kernel_ns': kernel_ns})
    return rows


def replay_of_limit(results: dict) -> list[float]:
    """Return each replay's share of its kernel-only limit, in the order of ``results['replay']``.

    The limit is the bare kernel's median step, timed beside that replay, times the
    session's 120 Hz steps: a replay that did nothing but step the cloth.

    :param results: what :func:`run` returned.
    :returns: one share per replay.
    """
    return [r['session_s'] * RATE * r['kernel_ns'] * 1e-9 / r['replay_s']
            for r in results['replay']]
