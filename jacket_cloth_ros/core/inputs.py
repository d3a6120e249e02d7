# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Turning one JointState's content into a skeleton sample, with every bad case named.

World motion convention (documented in the README): the character's pose in the world frame
travels in the same JointState as six-plus-one variables of a floating virtual joint, named as
MoveIt names them: ``<world_joint>/trans_x``, ``trans_y``, ``trans_z``, ``rot_x``, ``rot_y``,
``rot_z``, ``rot_w`` (the URDF root link's pose in the world frame, metres and a quaternion).
Carrying it in the JointState keeps body and world motion on one stamp, so replay is exact.
"""

from dataclasses import dataclass, field

import numpy as np

from .transforms import make_transform, quat_to_matrix

WORLD_VARIABLES = ('trans_x', 'trans_y', 'trans_z', 'rot_x', 'rot_y', 'rot_z', 'rot_w')


class InputRejected(ValueError):
    """The message cannot be used at all; ``code`` names the case for rate-limited logging."""

    def __init__(self, code, text):
        super().__init__(text)
        self.code = code


@dataclass
class Sample:
    stamp_ns: int
    q: np.ndarray            # joint values in skeleton.joint_names order
    root: np.ndarray         # 4x4 pose of the root link in the world frame
    root_quat: np.ndarray    # (x, y, z, w) of that pose, for interpolation
    warnings: list = field(default_factory=list)   # (code, text) of usable-but-odd input


class InputParser:
    """Maps names to skeleton joints; holds the last value of joints a message leaves out."""

    def __init__(self, skeleton, world_joint='world_joint'):
        self.skeleton = skeleton
        self.set_world_joint(world_joint)
        self.last_q = np.zeros(len(skeleton.joint_names))
        self.last_root = (np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))

    def set_world_joint(self, name):
        self.world_joint = name
        self.world_names = {f'{name}/{v}': k for k, v in enumerate(WORLD_VARIABLES)}

    def parse(self, stamp_ns, names, positions):
        names = list(names)
        positions = np.asarray(positions, dtype=float)
        if len(names) == 0 and len(positions) == 0:
            raise InputRejected('empty', 'empty JointState (no names, no positions): ignored')
        if len(names) != len(positions):
            raise InputRejected('length', f'JointState has {len(names)} names but '
                                f'{len(positions)} positions: message dropped')
        if not np.isfinite(positions).all():
            bad = [n for n, p in zip(names, positions) if not np.isfinite(p)]
            raise InputRejected('nonfinite', f'non-finite position for {", ".join(bad[:5])}: '
                                'message dropped')
        warnings = []
        q = self.last_q.copy()
        world = np.full(7, np.nan)
        seen = np.zeros(len(q), dtype=bool)
        unknown = []
        index = self.skeleton.joint_index
        for n, p in zip(names, positions):
            k = index.get(n)
            if k is not None:
                q[k] = p
                seen[k] = True
            elif n in self.world_names:
                world[self.world_names[n]] = p
            else:
                unknown.append(n)
        if unknown:
            warnings.append(('unknown', f'ignoring joint(s) not in the URDF: '
                             f'{", ".join(sorted(unknown)[:5])}'))
        if not seen.all():
            missing = [self.skeleton.joint_names[k] for k in np.nonzero(~seen)[0]]
            warnings.append(('missing', f'{len(missing)} joint(s) missing, holding their last '
                             f'value: {", ".join(missing[:5])}'))
        trans, quat = self.last_root
        got = ~np.isnan(world)
        if got.any():
            if not got.all():
                warnings.append(('world', f'incomplete {self.world_joint}/* pose: '
                                 'keeping the last world pose'))
            else:
                norm = np.linalg.norm(world[3:])
                if norm < 1e-6:
                    raise InputRejected('world', f'{self.world_joint} rotation is a zero '
                                        'quaternion: message dropped')
                trans, quat = world[:3].copy(), world[3:] / norm
        self.last_q = q
        self.last_root = (trans, quat)
        return Sample(stamp_ns, q, make_transform(quat_to_matrix(quat), trans), quat, warnings)
