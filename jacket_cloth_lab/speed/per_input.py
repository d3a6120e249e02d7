# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s input part: the node's pipeline per JointState against the bare kernel."""

import time

import numpy as np

from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.skeleton import Skeleton
from ..bench import rig_at_grid
from .measure import RATE, captured_steps, kernel_step_ns


def input_vs_kernel(skeleton: Skeleton, seconds: float = 10.0, paced_s: float = 3.0) -> dict:
    """Time the pipeline's CPU per JointState at 120 Hz against the bare kernel's for that step.

    One step per JointState; each figure is the median of its own run.

    Back to back, caches stay warm; a node gets its inputs 8.3 ms apart, and in between other
    processes evict its code and data.

    :param skeleton: the shipped character.
    :param seconds: how long the walk fed back to back runs.
    :param paced_s: how long it then runs paced: the same pipeline fed at 120 Hz with the
        wait slept away, the cost a live node's callback sees.
    """
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.motion.messages import clip_messages
    fabrics = load_fabrics()
    rig = rig_at_grid(skeleton, 9, 12)
    pipe = SessionPipeline(skeleton, rig, default_values(fabrics['tweed_jacket']),
                           timing=False)
    messages = list(clip_messages(skeleton, 'walk', RATE, seconds + paced_s, 10 ** 10))
    split = int(seconds * RATE)
    spent, paced = [], []
    for k, (stamp, msg) in enumerate(messages):
        t0 = time.thread_time_ns()
        pipe.on_joint_state(msg, stamp)
        (spent if k < split else paced).append(time.thread_time_ns() - t0)
        if k >= split:
            time.sleep(1.0 / RATE)
    kernel_ns = kernel_step_ns(captured_steps(skeleton, rig, fabrics['tweed_jacket']))
    input_ns = float(np.median(spent[2:]))
    paced_ns = float(np.median(paced))
    return {'input_us_median': input_ns * 1e-3, 'kernel_us_median': kernel_ns * 1e-3,
            'ratio': input_ns / kernel_ns, 'paced_us_median': paced_ns * 1e-3,
            'paced_ratio': paced_ns / kernel_ns}
