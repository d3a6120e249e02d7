# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A crowd character's input against a lone simulation's ``process``, side by side in one run.

Part of ``bench speed``'s crowd section (issue 34's one-node figures). Each 120 Hz walk
input goes, in turn, to a lone pipeline (``SessionPipeline.on_joint_state``: the
simulation's ``process``, what jacket_cloth_node with one character and a replay run) and to
crowds of shipped characters (``CrowdPipeline.on_joint_states``, one thread) given the same
content as: the reader's one name list object (the steady way), a new name list object each
message (as rclpy's own deserialisation gives), a list that changes every message (turned
round every other one: never the steady way). Interleaved, so a drift in the machine's
speed reaches each alike.
"""

import statistics
import time
from typing import Dict, List

import numpy as np

from jacket_cloth_ros.core.skeleton import Skeleton

LONE = 'lone process'
WAYS = ('crowd, one name list', 'crowd, a new name list object each message',
        'crowd, a list that changes every message')
WARM_INPUTS = 20            # past the first inputs' resets and loads


def intake_vs_process(skeleton: Skeleton, characters: int = 8, inputs: int = 600) -> Dict:
    """Return the median thread CPU per character-input of each way, and its ratio to lone.

    :param skeleton: the character every pipeline simulates.
    :param characters: characters in each crowd.
    :param inputs: 120 Hz walk inputs sent to each way.
    :returns: ``{'characters', 'inputs', 'us': {way: us}, 'ratio': {way: x lone},
        'steady_inputs': {way: count}}``.
    """
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState

    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros import cdr
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import CrowdPipeline, SessionPipeline
    fabrics = load_fabrics()
    values = default_values(fabrics['tweed_jacket'])

    def pipeline():
        return SessionPipeline(skeleton, load_rig(skeleton), values, timing=False)
    lone = pipeline()
    crowds = {way: CrowdPipeline(1) for way in WAYS}
    for crowd in crowds.values():
        for _ in range(characters):
            crowd.add(pipeline())
    reader = cdr.JointStateReader()
    spent: Dict[str, List[float]] = {way: [] for way in (LONE,) + WAYS}
    for k in range(inputs):
        names, positions = joint_state_content(skeleton.joint_names, 'walk', k / 120)
        stamp = 10 ** 10 + round(k * 1e9 / 120)
        raw = cdr.joint_state(stamp, names, positions)
        same = reader.read(raw)
        fresh = []
        for _ in range(characters):
            msg = deserialize_message(raw, JointState)
            fresh.append(cdr.JointStateContent(stamp, tuple(msg.name), np.array(msg.position)))
        turned = (cdr.JointStateContent(stamp, same.name[::-1], same.position[::-1].copy())
                  if k % 2 else same)
        started = time.thread_time_ns()
        lone.on_joint_state(fresh[0], stamp)
        spent[LONE].append(time.thread_time_ns() - started)
        for way, contents in zip(WAYS, ([same] * characters, fresh, [turned] * characters)):
            started = time.thread_time_ns()
            crowds[way].on_joint_states(list(enumerate(contents)))
            spent[way].append((time.thread_time_ns() - started) / characters)
    us = {way: statistics.median(got[WARM_INPUTS:]) / 1e3 for way, got in spent.items()}
    return {'characters': characters, 'inputs': inputs, 'us': us,
            'ratio': {way: us[way] / us[LONE] for way in us},
            'steady_inputs': {way: c.steps.steady_inputs for way, c in crowds.items()}}


def summary(intake: Dict) -> List[str]:
    """Markdown lines of the intake figures.

    :param intake: what :func:`intake_vs_process` returned.
    """
    lines = [f'A crowd character\'s input against a lone simulation\'s `process` (thread CPU '
             f'per character-input, median of {intake["inputs"] - WARM_INPUTS} inputs, crowds '
             f'of {intake["characters"]}, interleaved in one thread):', '',
             '| input | us | / lone process |', '|---|---|---|']
    for way, us in intake['us'].items():
        lines.append(f'| {way} | {us:.0f} | {intake["ratio"][way]:.2f}x |')
    return lines
