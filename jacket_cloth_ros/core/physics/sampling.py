# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A JointState's values as a skeleton sample, and how far the root moved between two (numba).

Compiled: in numpy each was a visible share of every input. inputs.InputParser plans a
message's names and names every bad case; the crowd's compiled intake (physics.crowd) uses
the same two functions, so both ways agree to the bit.
"""

import numpy as np

from ..compiled import njit
from .pose import quat_matrix

FILLED, NON_FINITE_POSITION, ZERO_QUATERNION = range(3)    # what fill_sample found


@njit(cache=True)
def fill_sample(positions, plan, last, new):
    """Fill the bundles.JointSample ``new`` from one message's positions by its NamePlan.

    Joints and a world pose the message leaves out keep their values in ``last``; a value the
    plan does not take (a name not in the URDF) is not looked at. A continuous joint's angle
    is taken within half a turn of its last value: the steps interpolate between the two, and
    a driver's angle wrapped at +-pi turned the body the long way round. Compiled: in numpy
    it was a visible share of every input.
    """
    q, root, quat = new.q, new.root, new.quat
    joint_from, joint_to, world_from, world_to = (plan.joint_from, plan.joint_to,
                                                  plan.world_from, plan.world_to)
    for k in range(joint_from.shape[0]):
        if not np.isfinite(positions[joint_from[k]]):
            return NON_FINITE_POSITION
    if plan.whole_world:
        for k in range(world_from.shape[0]):
            if not np.isfinite(positions[world_from[k]]):
                return NON_FINITE_POSITION
    q[:] = last.q
    wraps = plan.wraps
    for k in range(joint_from.shape[0]):
        value = positions[joint_from[k]]
        if wraps[k]:
            before = last.q[joint_to[k]]
            turns = np.floor((value - before) / (2.0 * np.pi) + 0.5)
            value -= 2.0 * np.pi * turns
        q[joint_to[k]] = value          # a repeated name: the last one counts
    if not plan.whole_world:
        root[:] = last.root
        quat[:] = last.quat
        return FILLED
    world = np.empty(7)
    for k in range(world_from.shape[0]):
        world[world_to[k]] = positions[world_from[k]]
    # Scaled by the largest component: squares of 1e200 overflow and those of 1e-200 vanish.
    big = max(abs(world[3]), abs(world[4]), abs(world[5]), abs(world[6]))
    if big < 1e-6:
        return ZERO_QUATERNION
    norm = big * np.sqrt((world[3] / big) ** 2 + (world[4] / big) ** 2 + (world[5] / big) ** 2
                         + (world[6] / big) ** 2)
    for k in range(4):
        quat[k] = world[3 + k] / norm
    root[:] = 0.0
    root[3, 3] = 1.0
    quat_matrix(quat, root)
    root[:3, 3] = world[:3]
    return FILLED


@njit(cache=True)
def root_jump(root_a, root_b, quat_a, quat_b):
    """How far (m) and through what angle (degrees) the root moved from sample a to b.

    The turn between unit quaternions is 2 acos |q_a . q_b| (q and -q: the same rotation).
    Compiled: in numpy it cost a visible share of every input, more so in a node that
    sleeps between inputs.
    """
    d0 = root_b[0, 3] - root_a[0, 3]
    d1 = root_b[1, 3] - root_a[1, 3]
    d2 = root_b[2, 3] - root_a[2, 3]
    dot = abs(quat_a[0] * quat_b[0] + quat_a[1] * quat_b[1] + quat_a[2] * quat_b[2]
              + quat_a[3] * quat_b[3])
    return np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), np.degrees(2.0 * np.arccos(min(1.0, dot)))
