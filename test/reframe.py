# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The same character with other link axes: a URDF, its rig and its motion re-expressed.

Every link frame L becomes L @ R_L (R_L a rotation given per link, e.g. the Y-up frames of BVH
and game skeletons: x forward, y up, z right, bones along -y). The skeleton, its motion and
the rig stay the same body; only the numbers that name them change:

- :func:`rotate_urdf`: joint origins and axes, and the links' visual, collision and inertial
  origins, re-expressed in the new frames;
- :func:`rotate_rig`: every rig number given in a link's frame (shape centre, pads, aims, hood,
  colliders) and, since the world is the root link's frame with the world joint at identity,
  the world's numbers (``up``, ``forward``, world planes) in the new root frame;
- :func:`rotate_joint_state`: the world joint's pose of the new root.

So the simulation of the re-expressed character must give the same cloth, hood and bones, up to
the frame change: the test of "no hidden axis conventions" (issue 18), and a way to make a Y-up
skeleton for the rig proposer's tests.
"""

import copy
import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence

import numpy as np

from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
from jacket_cloth_ros.core.transforms import matrix_to_quat, quat_to_matrix, rpy_matrix

# Columns: the new x, y, z in the old (REP 103) frame: x forward, y up, z right.
Y_UP = np.array([[1.0, 0.0, 0.0],
                 [0.0, 0.0, -1.0],
                 [0.0, 1.0, 0.0]])

Rotations = Callable[[str], np.ndarray]


def as_rotations(rotation: 'np.ndarray | dict | Rotations') -> Rotations:
    """Return a function link name -> R_L from one rotation, a dict or a function."""
    if callable(rotation):
        return rotation
    if isinstance(rotation, dict):
        return lambda name: np.asarray(rotation.get(name, np.eye(3)), dtype=float)
    fixed = np.asarray(rotation, dtype=float)
    return lambda name: fixed


def random_rotations(names: Sequence[str], seed: int = 0) -> dict:
    """Return a random rotation per link name (uniform, from normalised Gaussian quaternions)."""
    rng = np.random.default_rng(seed)
    out = {}
    for n in names:
        q = rng.normal(size=4)
        out[n] = quat_to_matrix(q / np.linalg.norm(q))
    return out


def matrix_rpy(r: np.ndarray) -> np.ndarray:
    """URDF roll, pitch, yaw (radians) of a rotation: the inverse of transforms.rpy_matrix."""
    pitch = np.arctan2(-r[2, 0], np.hypot(r[2, 1], r[2, 2]))
    if np.hypot(r[2, 1], r[2, 2]) < 1e-12:            # pitch at +-90 degrees: yaw takes it all
        return np.array([0.0, pitch, np.arctan2(-r[0, 1], r[1, 1])])
    return np.array([np.arctan2(r[2, 1], r[2, 2]), pitch, np.arctan2(r[1, 0], r[0, 0])])


def _text(values):
    return ' '.join(repr(float(v)) for v in values)


def _read(element, key, default):
    if element is None or element.get(key) is None:
        return np.array(default, dtype=float)
    return np.array([float(v) for v in element.get(key).split()])


def _reorigin(parent, tag, rot_left, rot_right):
    """Origin (R, t) of ``parent``'s <origin> to (rot_left^T R rot_right, rot_left^T t)."""
    origin = parent.find(tag)
    if origin is None:
        origin = ET.SubElement(parent, tag)
    xyz = _read(origin, 'xyz', [0, 0, 0])
    rot = rpy_matrix(_read(origin, 'rpy', [0, 0, 0]))
    origin.set('xyz', _text(rot_left.T @ xyz))
    origin.set('rpy', _text(matrix_rpy(rot_left.T @ rot @ rot_right)))


def rotate_urdf(urdf_xml: str, rotation: 'np.ndarray | dict | Rotations') -> str:
    """Return the URDF with every link frame L turned to L @ R_L, the same body otherwise."""
    rot = as_rotations(rotation)
    robot = ET.fromstring(urdf_xml)
    for link in robot.findall('link'):
        r = rot(link.get('name'))
        for tag in ('visual', 'collision', 'inertial'):
            for part in link.findall(tag):
                _reorigin(part, 'origin', r, np.eye(3))
    for joint in robot.findall('joint'):
        rp = rot(joint.find('parent').get('link'))
        rc = rot(joint.find('child').get('link'))
        _reorigin(joint, 'origin', rp, rc)
        if joint.get('type') in ('revolute', 'continuous', 'prismatic', 'planar'):
            axis = joint.find('axis')
            if axis is None:
                axis = ET.SubElement(joint, 'axis')
            axis.set('xyz', _text(rc.T @ _read(axis, 'xyz', [1, 0, 0])))
    return ET.tostring(robot, encoding='unicode')


def root_link(urdf_xml: str) -> str:
    """Return the name of the URDF's root link (the one no joint has as its child)."""
    robot = ET.fromstring(urdf_xml)
    children = {j.find('child').get('link') for j in robot.findall('joint')}
    return next(k.get('name') for k in robot.findall('link') if k.get('name') not in children)


def _deg(values):
    return [float(v) for v in np.degrees(values)]


def _vec(r, v):
    return [float(x) for x in r.T @ np.asarray(v, dtype=float)]


def rotate_rig(data: dict, rotation: 'np.ndarray | dict | Rotations', root: str,
               axes_at: Callable[[str], np.ndarray] | None = None) -> dict:
    """Return the rig data (as loaded from YAML) for the URDF that rotate_urdf made.

    ``root`` names the URDF's root link, whose frame is the world's at the zero pose.
    With ``axes_at`` (link name -> front, left, up of the original rig in that link's frame,
    e.g. ``lambda n: rig.axes_at(skeleton.link(n))``), the shape and the upper jacket get an
    explicit ``rpy_deg``; without, they keep inferring it from ``up`` and ``forward``.
    """
    rot = as_rotations(rotation)
    world = rot(root)
    out = copy.deepcopy(data)
    out['up'] = _vec(world, data.get('up', [0.0, 0.0, 1.0]))
    out['forward'] = _vec(world, data.get('forward', [1.0, 0.0, 0.0]))
    # The world is turned with the root: its up too, which is REP 103's +z unless said.
    out['world_up'] = _vec(world, data.get('world_up', [0.0, 0.0, 1.0]))

    def turn_part(part):
        r = rot(part['link'])
        if 'rpy_deg' in part:
            part['rpy_deg'] = _deg(matrix_rpy(r.T @ rpy_matrix(np.radians(part['rpy_deg']))))
        elif axes_at is not None:
            part['rpy_deg'] = _deg(matrix_rpy(r.T @ axes_at(part['link'])))
        return r

    shape = out['cloth']['shape']
    shape['center'] = _vec(turn_part(shape), shape['center'])
    hood = out['hood']
    r = rot(hood['link'])
    hood['pivot'] = _vec(r, hood['pivot'])
    hood['rest_direction'] = _vec(r, hood['rest_direction'])
    upper = out.get('jacket_bones', {}).get('upper')
    if upper is not None:
        r = turn_part(upper)
        for pad in upper['shoulder_pads'].values():
            pad['pivot'] = _vec(r, pad['pivot'])
            pad['aim'] = _vec(rot(pad['aim_link']), pad['aim'])
    for c in out.get('colliders', []):
        r = world if c['link'] == 'world' else rot(c['link'])
        kind = c.get('type', 'ellipsoid')
        if kind == 'ellipsoid':
            c['center'] = _vec(r, c['center'])
            turn = rpy_matrix(np.radians(c.get('rpy_deg', [0, 0, 0])))
            c['rpy_deg'] = _deg(matrix_rpy(r.T @ turn))
        elif kind == 'capsule':
            c['a'], c['b'] = _vec(r, c['a']), _vec(r, c['b'])
        else:
            c['point'], c['normal'] = _vec(r, c['point']), _vec(r, c['normal'])
    return out


def rotate_pose(root_pose: np.ndarray, world: np.ndarray) -> np.ndarray:
    """Return the new root's world pose (4x4) in the new world: R^T T R, R the root's turn."""
    r = np.eye(4)
    r[:3, :3] = world
    return r.T @ root_pose @ r


def rotate_joint_state(names: Sequence[str], positions: Sequence[float], world: np.ndarray,
                       world_joint: str = 'world_joint') -> list[float]:
    """Return a JointState's positions with the world joint's pose for the rotated root."""
    index = {n: k for k, n in enumerate(names)}
    keys = [index.get(f'{world_joint}/{v}') for v in WORLD_VARIABLES]
    out = [float(p) for p in positions]
    if any(k is None for k in keys):
        return out
    t = np.eye(4)
    t[:3, :3] = quat_to_matrix([out[k] for k in keys[3:]])
    t[:3, 3] = [out[k] for k in keys[:3]]
    turned = rotate_pose(t, world)
    for k, v in zip(keys, list(turned[:3, 3]) + list(matrix_to_quat(turned[:3, :3]))):
        out[k] = float(v)
    return out
