# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Turning one JointState's content into a skeleton sample, with every bad case named.

World motion convention (documented in the README): the character's pose in the world frame
travels in the same JointState as six-plus-one variables of a floating virtual joint, named as
MoveIt names them: ``<world_joint>/trans_x``, ``trans_y``, ``trans_z``, ``rot_x``, ``rot_y``,
``rot_z``, ``rot_w`` (the URDF root link's pose in the world frame, metres and a quaternion).
Carrying it in the JointState keeps body and world motion on one stamp, so replay is exact.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .kernel_cache import njit
from .step_kernel import quat_matrix

if TYPE_CHECKING:           # for the annotations only
    from .skeleton import Skeleton

WORLD_VARIABLES = ('trans_x', 'trans_y', 'trans_z', 'rot_x', 'rot_y', 'rot_z', 'rot_w')
FILLED, NON_FINITE_POSITION, ZERO_QUATERNION = range(3)    # what fill_sample found


class InputRejected(ValueError):
    """The message cannot be used at all; ``code`` names the case for rate-limited logging."""

    def __init__(self, code: str, text: str):
        super().__init__(text)
        self.code = code


@dataclass(slots=True)
class Sample:
    stamp_ns: int
    q: np.ndarray            # joint values in skeleton.joint_names order
    root: np.ndarray         # 4x4 pose of the root link in the world frame
    root_quat: np.ndarray    # (x, y, z, w) of that pose, for interpolation
    warnings: list = field(default_factory=list)   # (code, text) of usable-but-odd input


class InputParser:
    """Maps names to skeleton joints; holds the last value of joints a message leaves out."""

    def __init__(self, skeleton: 'Skeleton', world_joint: str = 'world_joint'):
        self.skeleton = skeleton
        self.set_world_joint(world_joint)
        self.last_q = np.zeros(len(skeleton.joint_names))
        self.last_root, self.last_quat = np.eye(4), np.array([0.0, 0.0, 0.0, 1.0])

    def set_world_joint(self, name: str) -> None:
        self.world_joint = name
        self.world_names = {f'{name}/{v}': k for k, v in enumerate(WORLD_VARIABLES)}
        self._plans = {}

    def plan(self, names: tuple[str, ...]) -> tuple:
        """Return where each name of a message goes, and the warnings its name list earns.

        (joint_from, joint_to, world_from, world_to, whole_world, warnings), worked out once
        per distinct name list (a publisher sends the same list every time).
        """
        plan = self._plans.get(names)
        if plan is not None:
            return plan
        index = self.skeleton.joint_index
        joint_from, joint_to, world_from, world_to, unknown = [], [], [], [], []
        for i, n in enumerate(names):
            if n in index:
                joint_from.append(i)
                joint_to.append(index[n])
            elif n in self.world_names:
                world_from.append(i)
                world_to.append(self.world_names[n])
            else:
                unknown.append(n)
        warnings = []
        if unknown:
            warnings.append(('unknown', f'ignoring joint(s) not in the URDF: '
                             f'{", ".join(sorted(unknown)[:5])}'))
        missing = sorted(set(range(len(index))) - set(joint_to))
        if missing:
            text = ', '.join(self.skeleton.joint_names[k] for k in missing[:5])
            warnings.append(('missing', f'{len(missing)} joint(s) missing, holding their last '
                             f'value: {text}'))
        world = len(set(world_to))
        if 0 < world < len(WORLD_VARIABLES):
            warnings.append(('world', f'incomplete {self.world_joint}/* pose: '
                             'keeping the last world pose'))
        plan = (np.array(joint_from, dtype=np.int64), np.array(joint_to, dtype=np.int64),
                np.array(world_from, dtype=np.int64), np.array(world_to, dtype=np.int64),
                world == len(WORLD_VARIABLES), warnings)
        if len(self._plans) > 16:           # a publisher that changes its list every time
            self._plans.clear()
        self._plans[names] = plan
        return plan

    def parse(self, stamp_ns: int, names: Sequence[str], positions: npt.ArrayLike) -> Sample:
        names = tuple(names)
        positions = np.asarray(positions, dtype=float)
        if len(names) == 0 and len(positions) == 0:
            raise InputRejected('empty', 'empty JointState (no names, no positions): ignored')
        if len(names) != len(positions):
            raise InputRejected('length', f'JointState has {len(names)} names but '
                                f'{len(positions)} positions: message dropped')
        joint_from, joint_to, world_from, world_to, whole_world, warnings = self.plan(names)
        q, root, quat = np.empty_like(self.last_q), np.empty((4, 4)), np.empty(4)
        found = fill_sample(positions, joint_from, joint_to, world_from, world_to, whole_world,
                            self.last_q, self.last_root, self.last_quat, q, root, quat)
        if found == NON_FINITE_POSITION:
            bad = [n for n, p in zip(names, positions) if not np.isfinite(p)]
            raise InputRejected('nonfinite', f'non-finite position for {", ".join(bad[:5])}: '
                                'message dropped')
        if found == ZERO_QUATERNION:
            raise InputRejected('world', f'{self.world_joint} rotation is a zero '
                                'quaternion: message dropped')
        self.last_q, self.last_root, self.last_quat = q, root, quat
        return Sample(stamp_ns, q, root, quat, list(warnings))


@njit(cache=True)
def fill_sample(positions, joint_from, joint_to, world_from, world_to, whole_world, last_q,
                last_root, last_quat, q, root, quat):
    """Fill a sample's joint values ``q``, root pose ``root`` and unit quaternion ``quat``.

    From one message's positions by its plan; joints and a world pose it leaves out keep their
    last values. Compiled: in numpy it was a visible share of every input.
    """
    for k in range(positions.shape[0]):
        if not np.isfinite(positions[k]):
            return NON_FINITE_POSITION
    q[:] = last_q
    for k in range(joint_from.shape[0]):
        q[joint_to[k]] = positions[joint_from[k]]        # a repeated name: the last one counts
    if not whole_world:
        root[:] = last_root
        quat[:] = last_quat
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
