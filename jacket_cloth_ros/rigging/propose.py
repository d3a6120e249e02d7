# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Propose a jacket rig for a URDF skeleton: find the body parts, size the cloth, write YAML.

Everything is found at the URDF's zero pose in the root frame, whatever the links' own axes:
the pelvis is the first link where two legs and the spine part, the chest the first link above
it where two arms and the neck part (chains from the root); sensor and virtual frames (an IMU,
a camera, massless shapeless links of a robot) are no part of any chain; each arm's shoulder,
elbow and wrist are where its two longest consecutive bones meet, a joint that only twists a
straight bone halfway along it joining the two, a link fixed to the one before no bend, and
bends closer than a share of the longest bone one joint; left and right come from the names
(REP-120 ``l_``, Mixamo ``mixamorig:Left``, Unreal ``_l``, SMPL ``L_``) or else from the side
they are on. Names also choose between links that sit at one place (a clavicle and an upper
arm, three links of one ball joint). Sizes come from the links' URDF ``<collision>`` shapes
when they have primitives, else from a robot torso's inertia or from bone lengths; the M10
colliders cover every spine and leg bone the jacket hangs over (issue 35 item 3). Positions
and vectors are written in each link's frame, so the rig fits whatever the link axes are.
"""

import re
from dataclasses import dataclass, field
from xml.etree import ElementTree

import numpy as np
import yaml

from ..core.config import ConfigError
from ..core.rig import REP103_UP
from ..core.urdf_colliders import urdf_shapes
from ..core.skeleton import Skeleton
from ..core.transforms import rpy_matrix, snapped_to_axis

SAME_PLACE = 1e-3           # m: links closer than this sit at one joint
FOOT_AHEAD = 0.04           # of the height: toes this far ahead of the ankle say forward
ALONG = 0.9                 # cosine: a joint axis or a bone this close to a bone is along it
JOINT_SHARE = 0.15          # of an arm's longest bone: bends closer than this are one joint
END = -1                    # the end of an arm that ends at the elbow: a wrist with no link
# A bone collider's radius as a share of the height: a thigh's for a person, thicker than the
# body proxy's bones (core.body_proxy, a knee's), so cloth the colliders hold is outside those.
BONE_COLLIDER_SHARE = 0.04
TORSO_GAP = 0.02            # m at 1.75 m tall: the top row outside a robot's torso box
# m: a link whose shapes are all smaller than this (a camera frame's marker sphere) has no
# body to speak of: with no mass too, it is a sensor or virtual frame (issue 47 item 3).
MARKER_SIZE = 0.005

#  Words of sensor and virtual frames (an IMU, a camera, a lidar): never a part of the body.
SENSOR_WORDS = {'imu', 'camera', 'cam', 'lidar', 'laser', 'sensor', 'gyro', 'gyrometer',
                'accelerometer', 'rgbd', 'optical', 'depth', 'sonar', 'ranger', 'kinect',
                'realsense', 'velodyne', 'hokuyo', 'livox', 'gaze', 'fsr', 'touch'}

#  Name tables: token sets that name a part, strongest first (tokens: the name cut at _ : . -,
#  digits and camel case, lower case, side tokens removed).
NAMES = {
    'pelvis': [{'pelvis'}, {'hips'}, {'hip'}, {'root'}, {'base'}],
    'spine': [{'spine'}, {'chest'}, {'torso'}, {'waist'}, {'abdomen'}, {'back'}],
    'neck': [{'neck'}, {'head'}],
    'upper_arm': [{'upperarm'}, {'upper', 'arm'}, {'arm'}, {'humerus'}, {'shoulder'}],
    'forearm': [{'forearm'}, {'lowerarm'}, {'fore', 'arm'}, {'lower', 'arm'}, {'elbow'}],
    'hand': [{'hand'}, {'wrist'}],
    'thigh': [{'thigh'}, {'upleg'}, {'up', 'leg'}, {'upper', 'leg'}, {'thigh'}, {'femur'},
              {'hip'}],
}
LEFT, RIGHT = {'l', 'left'}, {'r', 'right'}


def tokens(name: str) -> list[str]:
    """Cut a link name into lower-case words: ``mixamorig:LeftUpLeg`` -> mixamorig left up leg.

    :param name: the link's name.
    """
    spaced = re.sub(r'([a-z])([A-Z])', r'\1 \2', name)
    spaced = re.sub(r'([A-Z]+)([A-Z][a-z])', r'\1 \2', spaced)
    return [t for t in re.split(r'[^A-Za-z]+', spaced.lower()) if t]


def side_of(name: str) -> str | None:
    """Return 'left', 'right' or None from a link name's words.

    :param name: the link's name.
    """
    words = set(tokens(name))
    if words & LEFT and not words & RIGHT:
        return 'left'
    if words & RIGHT and not words & LEFT:
        return 'right'
    return None


def name_rank(name: str, part: str) -> int | None:
    """Return how strongly a name says ``part`` (0 strongest), None if it does not.

    :param name: the link's name.
    :param part: a body part, a key of ``NAMES`` (``thigh``).
    """
    words = set(tokens(name)) - LEFT - RIGHT
    joined = ''.join(tokens(name))
    for rank, want in enumerate(NAMES[part]):
        if want <= words or (len(want) == 1 and next(iter(want)) in words):
            return rank
        if len(want) > 1 and ''.join(sorted(want)) in joined:
            return rank
    return None


@dataclass
class Choice:
    """A link chosen for a part of the body, and why."""

    part: str
    link: str
    why: str


@dataclass
class Body:
    """The parts of a skeleton found at its zero pose (root frame)."""

    skeleton: Skeleton
    rest: np.ndarray                    # (L,4,4) link frames at the zero pose
    pelvis: int
    chest: int
    spine: list                         # link ids from pelvis to chest
    neck: int
    arms: dict                          # side -> (upper, forearm, hand) link ids
    thighs: dict                        # side -> link id
    knees: dict                         # side -> position of the knee
    up: np.ndarray
    forward: np.ndarray
    left: np.ndarray
    height: float
    tips: np.ndarray | None = None      # (L,3) where each link's body ends (_tips)
    virtual: list = field(default_factory=list)   # sensor and virtual frames, left out
    frames: 'Frames | None' = None      # masses and inertias (_frames)
    choices: list = field(default_factory=list)
    ankles: dict = field(default_factory=dict)      # side -> the link at the ankle
    # side -> where an arm that ends at the elbow ends (root frame): its hand is its forearm
    arm_ends: dict = field(default_factory=dict)

    def pos(self, link: int) -> np.ndarray:
        """Return a link's origin at the zero pose, (3,) in the root frame.

        :param link: the link's index.
        """
        return self.rest[link][:3, 3]

    def name(self, link: int) -> str:
        """Return a link's name.

        :param link: the link's index.
        """
        return self.skeleton.link_names[link]


class Refusal(ConfigError):
    """The skeleton lacks a torso or two arms: no rig can be proposed."""


@dataclass
class Frames:
    """What the URDF says of each link beyond the kinematics: mass, inertia, shapes."""

    mass: np.ndarray                    # (L,) kg; 0 when none is given
    com: np.ndarray                     # (L,3) centre of mass in the link's frame
    shaped: np.ndarray                  # (L,) bool: a <visual> or <collision> over MARKER_SIZE
    inertia: np.ndarray | None = None   # (L,3,3) about the centre of mass, the link's axes


def _frames(sk):
    n = len(sk.link_names)
    out = Frames(np.zeros(n), np.zeros((n, 3)), np.zeros(n, bool), np.zeros((n, 3, 3)))
    try:
        robot = ElementTree.fromstring(sk.urdf_xml.rstrip('\0 \r\n\t'))
    except ElementTree.ParseError:
        return out
    for link in robot.findall('link'):
        k = sk.link_index.get(link.get('name', ''))
        if k is None:
            continue
        out.shaped[k] = any(_shape_size(g) > MARKER_SIZE
                            for g in link.findall('visual/geometry')
                            + link.findall('collision/geometry'))
        try:
            mass = link.find('inertial/mass')
            out.mass[k] = float(mass.get('value', 0)) if mass is not None else 0.0
            origin = link.find('inertial/origin')
            if origin is not None:
                out.com[k] = [float(v) for v in origin.get('xyz', '0 0 0').split()]
            out.inertia[k] = _inertia(link)
        except ValueError:
            continue                      # no use for a bad inertial: the link is as if without
    bad = ~np.isfinite(out.mass) | ~np.isfinite(out.com).all(axis=1) \
        | ~np.isfinite(out.inertia).all(axis=(1, 2))
    out.mass[bad], out.com[bad], out.inertia[bad] = 0.0, 0.0, 0.0
    return out


def _shape_size(geometry):
    """Return a URDF geometry's largest extent (m): a mesh or an unread shape counts as big."""
    try:
        for shape in geometry:
            if shape.tag == 'sphere':
                return 2 * float(shape.get('radius', 'inf'))
            if shape.tag == 'box':
                return max(float(v) for v in shape.get('size', 'inf').split())
            if shape.tag in ('cylinder', 'capsule'):
                return max(2 * float(shape.get('radius', 'inf')),
                           float(shape.get('length', 'inf')))
    except ValueError:
        pass
    return float('inf')


def _inertia(link):
    """Return a URDF link's inertia tensor in its frame (zeros without one)."""
    tensor = link.find('inertial/inertia')
    if tensor is None:
        return np.zeros((3, 3))
    g = {key: float(tensor.get(key, 0)) for key in ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')}
    i = np.array([[g['ixx'], g['ixy'], g['ixz']], [g['ixy'], g['iyy'], g['iyz']],
                  [g['ixz'], g['iyz'], g['izz']]])
    origin = link.find('inertial/origin')
    rpy = [float(v) for v in origin.get('rpy', '0 0 0').split()] if origin is not None else [0] * 3
    r = rpy_matrix(np.array(rpy))
    return r @ i @ r.T


def is_sensor_name(name: str) -> bool:
    """Tell whether a link name says a sensor frame (``imu_in_torso``, ``rgbd_optical_frame``).

    :param name: the link's name.
    """
    return any(t in SENSOR_WORDS or t.endswith(('sensor', 'camera')) for t in tokens(name))


def virtual_links(sk: Skeleton, frames: Frames | None = None) -> list[int]:
    """Return the sensor and virtual frames: links that are no part of the body.

    A link whose name says a sensor (IMU, camera, lidar, laser, ``*_sensor``) or, in a URDF that
    gives masses, a link with no mass and no visual or collision shape over MARKER_SIZE
    (whatever its name: a camera frame's 1 mm marker sphere is no body), when every link below it
    is such a frame too (a sensor frame that carries a gripper is part of the arm). A skeleton
    without masses (BVH import, an animation rig) keeps its shapeless end links: they are its
    bones' ends.

    :param sk: the skeleton.
    :param frames: what its URDF says of each link (masses, shapes); None: read here.
    """
    frames = frames or _frames(sk)
    masses = bool((frames.mass > 0).any())
    n = len(sk.link_names)
    has_body_below = np.zeros(n, bool)
    virtual = np.zeros(n, bool)
    for k in range(n - 1, 0, -1):              # breadth-first order: children later
        empty = masses and frames.mass[k] <= 0 and not frames.shaped[k]
        virtual[k] = not has_body_below[k] and (is_sensor_name(sk.link_names[k]) or empty)
        if not virtual[k]:
            has_body_below[sk.parent[k]] = True
    return [k for k in range(n) if virtual[k]]


def _children(sk, skip=()):
    kids = [[] for _ in sk.link_names]
    skip = set(skip)
    for k, p in enumerate(sk.parent):
        if p >= 0 and k not in skip:
            kids[p].append(k)
    return kids


def _tips(sk, rest, kids, frames):
    """Return where each link's body ends: an end link's centre of mass, else its origin.

    A head fixed to the torso with its frame at the torso's, or a forearm that ends the arm,
    reaches as far as its mass does, not to its frame.
    """
    tips = rest[:, :3, 3].copy()
    for k in range(len(sk.link_names)):
        if not kids[k] and frames.mass[k] > 0:
            tips[k] = rest[k][:3, :3] @ frames.com[k] + rest[k][:3, 3]
    return tips


def _reach(sk, rest, kids, tips):
    """Longest distance from each link's origin down to a leaf of its subtree, along bones."""
    reach = np.linalg.norm(tips - rest[:, :3, 3], axis=1)
    for k in range(len(sk.link_names) - 1, -1, -1):      # breadth-first order: children later
        for c in kids[k]:
            bone = np.linalg.norm(rest[c][:3, 3] - rest[k][:3, 3])
            reach[k] = max(reach[k], reach[c] + bone)
    return reach


def _leaves(k, kids):
    """Count the leaves below link ``k``: a walk with its own stack, not Python's.

    A URDF may hang a chain of a thousand links (a tail, a cable) where a recursion per
    link ran out of Python's frames.
    """
    count, stack = 0, [k]
    while stack:
        j = stack.pop()
        if kids[j]:
            stack.extend(kids[j])
        else:
            count += 1
    return count


def _branches(k, kids, rest, reach, least):
    """Return the children of ``k`` that start a long chain (at least ``least`` m from k)."""
    out = []
    for c in kids[k]:
        if reach[c] + np.linalg.norm(rest[c][:3, 3] - rest[k][:3, 3]) >= least:
            out.append(c)
    return out


def _main_path(k, kids, reach):
    """From link k down its longest chain to a leaf."""
    path = [k]
    while kids[path[-1]]:
        path.append(max(kids[path[-1]], key=lambda c: reach[c]))
    return path


def _moving(path, sk):
    """Leave out a limb path's links fixed to the one before (no joint bends there).

    The path's end is kept. iCub's upper arm link halfway down the upper arm; its hip's link
    fixed in the thigh, before the link that turns the leg at the hip (down and back up).
    """
    return [k for k in path[:-1] if sk.kind[k] >= 0] + path[-1:]


def _groups(path, rest):
    """Consecutive links of a path grouped by where they sit (one joint: several links)."""
    groups = [[path[0]]]
    for k in path[1:]:
        if np.linalg.norm(rest[k][:3, 3] - rest[groups[-1][-1]][:3, 3]) < SAME_PLACE:
            groups[-1].append(k)
        else:
            groups.append([k])
    return groups


def _bends(groups, rest, sk):
    """Return the groups where a chain can bend, and the links left out as twist joints.

    A joint that turns only about the bone it sits on, halfway along a straight run (a robot's
    upper-arm yaw or forearm roll), twists that bone: it is neither a shoulder, an elbow nor a
    wrist, and the bones on either side of it are one.
    """
    pts = [rest[g[0]][:3, 3] for g in groups]
    keep, twists = [groups[0]], []
    for i in range(1, len(groups) - 1):
        d_in, d_out = pts[i] - pts[i - 1], pts[i + 1] - pts[i]
        d_in, d_out = (d / max(np.linalg.norm(d), 1e-12) for d in (d_in, d_out))
        turning = [k for k in groups[i] if sk.kind[k] >= 0]
        twist = (d_in @ d_out >= ALONG and bool(turning)
                 and all(sk.kind[k] == 0 and abs((rest[k][:3, :3] @ sk.axis[k]) @ d_in) >= ALONG
                         for k in turning))
        if twist:
            twists += groups[i]
        else:
            keep.append(groups[i])
    return keep + groups[-1:] if len(groups) > 1 else keep, twists


def _pick(group, part, sk):
    """Return the link of a group that names ``part`` best, else the last (it carries the bone)."""
    ranked = [(name_rank(sk.link_names[k], part), -i, k) for i, k in enumerate(group)]
    named = [r for r in ranked if r[0] is not None]
    if named:
        rank, _, k = min(named)
        return k, f'its name says {part.replace("_", " ")}'
    return group[-1], 'by topology'


def find_body(sk: Skeleton, forward: np.ndarray | None = None) -> Body:
    """Find pelvis, spine, chest, neck, arms and thighs of a skeleton; refuse in one line.

    :param sk: the skeleton.
    :param forward: the direction the character faces, in its root frame; None: inferred.
    """
    rest = sk.forward(np.zeros(len(sk.joint_names)))
    frames = _frames(sk)
    virtual = virtual_links(sk, frames)
    kids = _children(sk, virtual)
    tips = _tips(sk, rest, kids, frames)
    reach = _reach(sk, rest, kids, tips)
    pts = rest[:, :3, 3]
    size = float(np.ptp(pts, axis=0).max()) if len(pts) > 1 else 0.0
    if size <= 0:
        raise Refusal('cannot find a torso: the skeleton has no bones')
    least = 0.15 * size
    # Pelvis: the first link, from the root, where three long chains part (two legs, spine).
    pelvis = None
    for k in range(len(sk.link_names)):
        if len(_branches(k, kids, rest, reach, least)) >= 3:
            pelvis = k
            break
    if pelvis is None:
        raise Refusal('cannot find a torso: no link where two legs and a spine part '
                      f'(links: {", ".join(sk.link_names[:12])}'
                      f'{", ..." if len(sk.link_names) > 12 else ""})')
    branches = _branches(pelvis, kids, rest, reach, least)
    # The spine carries the most ends (head and two hands); names break ties.
    spine_root = max(branches, key=lambda c: (_leaves(c, kids),
                                              name_rank(sk.link_names[c], 'spine') is not None,
                                              reach[c]))
    legs = [c for c in branches if c != spine_root]
    # Chest: the first link up the spine where three long chains part (two arms and the neck).
    chest, k = None, spine_root
    spine = [pelvis]
    while k is not None:
        spine.append(k)
        if len(_branches(k, kids, rest, reach, least * 0.6)) >= 3:
            chest = k
            break
        nxt = _branches(k, kids, rest, reach, least * 0.6)
        k = max(nxt, key=lambda c: reach[c]) if nxt else None
    if chest is None:
        raise Refusal('cannot find two arms: no link up the spine from '
                      f'{sk.link_names[pelvis]!r} where two arms and a neck part')
    tops = _branches(chest, kids, rest, reach, least * 0.6)
    neck_root = min(tops, key=lambda c: (name_rank(sk.link_names[c], 'neck') is None,
                                         reach[c]))
    arms_roots = [c for c in tops if c != neck_root]
    if len(arms_roots) < 2:
        raise Refusal(f'cannot find two arms at {sk.link_names[chest]!r}')
    arms_roots = sorted(arms_roots, key=lambda c: -reach[c])[:2]
    neck_path = _groups(_main_path(neck_root, kids, reach), rest)
    up = snapped_to_axis(tips[neck_path[-1][-1]] - pts[pelvis])
    if forward is None:
        fwd, why_fwd = _infer_forward(sk, rest, kids, reach, pelvis, legs[:2], arms_roots, up,
                                      size)
    else:
        fwd, why_fwd = np.asarray(forward, float), 'given by --forward'
    fwd = fwd - (fwd @ up) * up
    if np.linalg.norm(fwd) < 1e-3:
        raise Refusal('forward is along up: give another forward direction')
    fwd = snapped_to_axis(fwd)
    left = np.cross(up, fwd)
    # Each arm's mean point (its chain's links): both arms' roots may share one point.
    arm_at = [pts[_main_path(c, kids, reach)].mean(axis=0) for c in arms_roots]
    apart = arm_at[0] - arm_at[1]
    if forward is not None and abs(apart @ left) < 0.25 * abs(apart @ fwd):
        # Across the body, the jacket's left and right fold onto each other (its shoulder
        # pads have no length); an arm ahead of the other at rest leaves them mostly apart
        # along left.
        given = ','.join(f'{v:g}' for v in np.asarray(forward, float))
        raise Refusal(f'--forward {given} runs across the body: its arms '
                      f'({sk.link_names[arms_roots[0]]}, {sk.link_names[arms_roots[1]]}) lie '
                      'side by side along it; give the way the character faces, or leave '
                      '--forward out (then the toes say it)')
    body = Body(sk, rest, pelvis, chest, spine, neck_root, {}, {}, {}, up, fwd, left,
                float(np.ptp(pts @ up)), tips=tips, virtual=virtual, frames=frames)
    nk, why = _pick(neck_path[0] if len(neck_path[0]) > 1 else [neck_root], 'neck', sk)
    body.neck = nk
    body.choices += [
        Choice('pelvis', sk.link_names[pelvis], 'first link from the root where two legs and '
               'the spine part'),
        Choice('chest', sk.link_names[chest], 'first link up the spine where two arms and the '
               'neck part'),
        Choice('neck', sk.link_names[nk], f'the short chain at the chest, {why}'),
        Choice('forward', '[' + ', '.join(f'{v:g}' for v in _r(fwd)) + ']', why_fwd)]
    if virtual:
        names = [sk.link_names[k] for k in virtual]
        shown = ', '.join(names[:8]) + (f' and {len(names) - 8} more' if len(names) > 8 else '')
        body.choices.append(Choice('not body parts', shown, 'sensor or virtual frames: a '
                                   'sensor\'s name, or no mass and no shape over a few mm'))
    for root in arms_roots:
        _arm(body, root, kids, reach)
    for root in legs[:2]:
        _leg(body, root, kids, reach)
    if set(body.arms) != {'left', 'right'}:
        raise Refusal('cannot find two arms: both arm chains are on one side')
    if set(body.thighs) != {'left', 'right'}:
        raise Refusal('cannot find two legs: both leg chains are on one side')
    return body


def _infer_forward(sk, rest, kids, reach, pelvis, legs, arms, up, size):
    """Return forward (root frame) and why: the feet, else the named sides, else +x.

    The toes point forward from the ankles in every rest pose (T, A or standing), whatever the
    names; the knees are straight at rest and the hips' offsets lean either way, so neither
    says it. Legs that end at the ankle leave the names: left and right links give left, and
    forward is left x up.
    """
    pts = rest[:, :3, 3]
    feet = []
    for root in legs:
        groups = _bends(_groups([pelvis] + _main_path(root, kids, reach), rest), rest, sk)[0]
        seg = [np.linalg.norm(pts[groups[i + 1][0]] - pts[groups[i][0]])
               for i in range(len(groups) - 1)]
        if not seg:
            continue
        thigh = max(1, next(j for j, b in enumerate(seg) if b >= 0.5 * max(seg)))
        if len(groups) <= thigh + 3:                  # no link beyond the ankle
            continue
        foot = pts[groups[-1][0]] - pts[groups[thigh + 2][0]]
        foot -= (foot @ up) * up
        if np.linalg.norm(foot) >= FOOT_AHEAD * size:
            feet.append(foot / np.linalg.norm(foot))
    if len(feet) == 2 and feet[0] @ feet[1] > 0.7:
        return feet[0] + feet[1], 'the toes point forward from the ankles'
    sides = {'left': [], 'right': []}
    for root in legs + arms:
        stack = [root]
        while stack:
            k = stack.pop()
            stack += kids[k]
            s = side_of(sk.link_names[k])
            if s:
                sides[s].append(pts[k])
    if sides['left'] and sides['right']:
        left = np.mean(sides['left'], axis=0) - np.mean(sides['right'], axis=0)
        left -= (left @ up) * up
        if np.linalg.norm(left) >= 0.02 * size:
            return np.cross(left, up), 'left and right by the names, forward = left x up'
    return np.array([1.0, 0.0, 0.0]), ('assumed +x: no toes ahead of the ankles and no named '
                                       'sides (give --forward)')


def _side(body, root, link):
    """Left or right from the names along the chain, else from where it is."""
    for k in (link, root):
        s = side_of(body.name(k))
        if s:
            return s, 'by name'
    d = (body.pos(link) - body.pos(body.chest)) @ body.left
    return ('left' if d > 0 else 'right'), 'by side'


def _arm(body, root, kids, reach):
    sk, rest = body.skeleton, body.rest
    groups, twists = _bends(_groups([body.chest] + _moving(_main_path(root, kids, reach), sk),
                                    rest), rest,
                            sk)
    groups = _one_joint(groups, rest) if len(groups) > 2 else groups
    pts = [rest[g[0]][:3, 3] for g in groups]
    # An arm that ends at the elbow (a robot whose forearm link carries the hand): its
    # forearm runs to where that link's body ends, a wrist without a link (END).
    end = _forearm_end(body, groups, kids)
    if end is not None:
        groups, pts = groups + [[END]], pts + [end]
    if len(groups) < 4:
        raise Refusal(f'cannot find two arms: the chain from {body.name(root)!r} has fewer '
                      'than three bones')
    seg = [np.linalg.norm(pts[i + 1] - pts[i]) for i in range(len(groups) - 1)]
    # Shoulder, elbow and wrist: where the two longest consecutive bones meet.
    i = max(range(1, len(seg) - 1), key=lambda j: seg[j] + seg[j + 1] - 1e-6 * j)
    upper, why_u = _pick(groups[i], 'upper_arm', sk)
    fore, why_f = _pick(groups[i + 1], 'forearm', sk)
    if groups[i + 2] == [END]:
        hand, why_h = fore, (f'none: the arm ends at the elbow, its forearm at {_r(pts[-1])} '
                             'where the link\'s inertia ends')
    else:
        hand, why_h = _pick(groups[i + 2], 'hand', sk)
    side, why_s = _side(body, root, upper)
    if side in body.arms:
        side = 'right' if side == 'left' else 'left'
        why_s = 'the other arm'
    body.arms[side] = (upper, fore, hand)
    if hand == fore:
        body.arm_ends[side] = pts[-1]
    twisted = [sk.link_names[k] for k in twists
               if groups[i][0] < k < groups[min(i + 2, len(groups) - 1)][0]]
    if twisted:
        why_s += f'; {", ".join(twisted)} only twist{"s" if len(twisted) == 1 else ""} a bone'
    body.choices += [
        Choice(f'{side} upper arm', sk.link_names[upper],
               f'shoulder of the two longest bones of the arm chain, {why_u}; {side} {why_s}'),
        Choice(f'{side} forearm', sk.link_names[fore], f'the elbow, {why_f}'),
        Choice(f'{side} hand', sk.link_names[hand] if hand != fore else '-',
               f'the wrist, {why_h}')]


def _forearm_end(body, groups, kids):
    """Return where an arm that ends at its elbow ends (root frame), else None.

    The chain's last link is a leaf whose name says elbow or forearm (not hand or wrist), or
    the chain has only a shoulder and that link: the link carries the forearm. Its end is
    half the inertia box's long side past its centre of mass, away from the link's origin (a
    rod's length from its moments); without an inertia, twice the centre of mass.
    """
    sk, frames = body.skeleton, body.frames
    last = groups[-1][-1]
    if kids[last] or frames is None or frames.mass[last] <= 0:
        return None
    names = [sk.link_names[k] for k in groups[-1]]
    says = any(name_rank(n, 'forearm') is not None for n in names) and not any(
        name_rank(n, 'hand') is not None for n in names)
    if not (says or len(groups) == 3):
        return None
    com = frames.com[last]
    if not np.linalg.norm(com) > 1e-3:
        return None
    ahead = com / np.linalg.norm(com)
    moments = np.sort(np.linalg.eigvalsh(frames.inertia[last]))
    long_side = np.sqrt(max(6.0 * (moments[1] + moments[2] - moments[0]) / frames.mass[last],
                            0.0))
    reach = np.linalg.norm(com) + 0.5 * long_side if long_side > 0 else 2 * np.linalg.norm(com)
    T = body.rest[last]
    return T[:3, :3] @ (ahead * reach) + T[:3, 3]


def _one_joint(groups, rest):
    """Join an arm's bends closer than JOINT_SHARE of its longest bone into one joint.

    An elbow of two joints a few cm apart (iCub's) is one elbow: its short link is no bone
    of the two longest. The chest's group, the first, stays apart.
    """
    pts = [rest[g[0]][:3, 3] for g in groups]
    longest = max(np.linalg.norm(b - a) for a, b in zip(pts[1:], pts[2:])) if len(pts) > 2 \
        else 0.0
    out = [list(groups[0]), list(groups[1])] if len(groups) > 1 else [list(groups[0])]
    for g, p in zip(groups[2:], pts[2:]):
        if np.linalg.norm(p - rest[out[-1][-1]][:3, 3]) < JOINT_SHARE * longest:
            out[-1] += g
        else:
            out.append(list(g))
    return out


def _leg(body, root, kids, reach):
    sk, rest = body.skeleton, body.rest
    groups = _bends(_groups([body.pelvis] + _moving(_main_path(root, kids, reach), sk), rest),
                    rest, sk)[0]
    seg = [np.linalg.norm(rest[groups[i + 1][0]][:3, 3] - rest[groups[i][0]][:3, 3])
           for i in range(len(groups) - 1)]
    if not seg:
        return
    # The thigh is the first long bone (a hip offset before it is short).
    i = next(j for j, s in enumerate(seg) if s >= 0.5 * max(seg))
    if i == 0:
        i = 1 if len(groups) > 1 else 0
        group = groups[i]
    else:
        group = groups[i]
    thigh, why = _pick(group, 'thigh', sk)
    side, why_s = _side(body, root, thigh)
    if side in body.thighs:
        side = 'right' if side == 'left' else 'left'
        why_s = 'the other leg'
    body.thighs[side] = thigh
    body.knees[side] = rest[groups[min(i + 1, len(groups) - 1)][0]][:3, 3]
    body.ankles[side] = groups[min(i + 2, len(groups) - 1)][0]
    body.choices.append(Choice(f'{side} thigh', sk.link_names[thigh],
                               f'first long bone of the leg chain, {why}; {side} {why_s}'))


# --- sizing and the YAML ---------------------------------------------------------------------

def _r(v, nd=3):
    return [round(float(x), nd) + 0.0 for x in v]


def _in_link(body, link, p):
    """Return a root-frame point in a link's frame."""
    T = body.rest[link]
    return T[:3, :3].T @ (p - T[:3, 3])


def _dir_in_link(body, link, d):
    return body.rest[link][:3, :3].T @ d


def _rpy_deg(R):
    """URDF roll-pitch-yaw (degrees) of a rotation."""
    pitch = np.arcsin(-np.clip(R[2, 0], -1, 1))
    roll = np.arctan2(R[2, 1], R[2, 2])
    yaw = np.arctan2(R[1, 0], R[0, 0])
    return _r(np.degrees([roll, pitch, yaw]), 2)


def _body_frame(body):
    return np.column_stack([body.forward, body.left, body.up])


def _aligned(body, link):
    """Tell whether the link's axes are the body's forward, left and up (no rpy_deg needed)."""
    return np.allclose(body.rest[link][:3, :3], _body_frame(body), atol=1e-4)


def _orient(body, link):
    """rpy_deg that turns the link's axes onto forward, left and up, or None if they are."""
    if _aligned(body, link):
        return None
    return _rpy_deg(body.rest[link][:3, :3].T @ _body_frame(body))


def _torso_extent(body, links):
    """Half-depth and half-width of the links' primitive collision shapes about the spine."""
    shapes = urdf_shapes(body.skeleton.urdf_xml)
    depth = width = 0.0
    found = []
    for k in links:
        for s in shapes.get(body.name(k), []):
            T = body.rest[k]
            c = T[:3, :3] @ s.xyz + T[:3, 3] - body.pos(body.pelvis)
            for axis, vec in (('d', body.forward), ('w', body.left)):
                e = abs(c @ vec) + s.extent(T[:3, :3].T @ vec)
                if axis == 'd':
                    depth = max(depth, e)
                else:
                    width = max(width, e)
            found.append(body.name(k))
    return depth, width, sorted(set(found))


def propose(sk: Skeleton, forward: list | None = None) -> tuple[dict, list[str], Body]:
    """Return the rig (a mapping for YAML), the lines saying what was chosen and why, the body.

    :param sk: the skeleton.
    :param forward: the direction the character faces, (3,) in its root frame; None: inferred.
    """
    body = find_body(sk, None if forward is None else np.asarray(forward, float))
    up, fwd, left = body.up, body.forward, body.left
    P = body.pos
    pelvis = P(body.pelvis)
    shoulder = {s: P(a[0]) for s, a in body.arms.items()}
    sh_height = np.mean([(p - pelvis) @ up for p in shoulder.values()])
    sh_half = abs((shoulder['left'] - shoulder['right']) @ left) / 2
    thigh_len = np.mean([np.linalg.norm(body.knees[s] - P(body.thighs[s])) for s in ('left',
                                                                                     'right')])
    s = max(body.height / 1.75, 0.1)       # the shipped character is 1.75 m tall
    lines = [f'{c.part:>15}: {c.link}  ({c.why})' for c in body.choices]
    # The cloth's top row at 0.38 of the way from the pelvis to the shoulders (as fitted by hand
    # on the shipped character), its hem 0.85 of a thigh below the hips.
    top_h = 0.38 * sh_height
    hem_h = min((P(body.thighs['left']) - pelvis) @ up, 0.0) - 0.85 * thigh_len
    spine_pts = [(k, (P(k) - pelvis) @ up) for k in body.spine]
    shape_link = body.spine[0]
    for k, h in spine_pts:
        if h <= top_h:
            shape_link = k
    # The thighs too: a hem narrower than their shapes would start inside them.
    torso_links = body.spine + [body.thighs['left'], body.thighs['right']]
    depth, width, with_shapes = _torso_extent(body, torso_links)
    ahead = 0.0                         # the cloth's centre ahead of the spine
    if with_shapes:
        ry = width + 0.02 * s
        rx = depth + 0.02 * s
        lines.append(f'{"cloth radii":>15}: from the <collision> shapes of '
                     + ', '.join(with_shapes))
    else:
        # Wide enough for the shoulders and for fleshy thighs below (0.19 of their length), and
        # clear of the leg bones' colliders, whichever is wider.
        hip_half = abs((P(body.thighs['left']) - P(body.thighs['right'])) @ left) / 2
        clear = BONE_COLLIDER_SHARE * body.height + 0.015 * s
        side_reach, front_reach = _leg_reach(body)
        torso = _inertia_torso(body, shape_link)
        if torso is None:
            ry = max(1.03 * sh_half, hip_half + 0.19 * thigh_len + 0.015 * s,
                     side_reach + clear)
            rx = max(0.8 * ry, front_reach + clear)
            lines.append(f'{"cloth radii":>15}: from the shoulder and hip widths '
                         f'({2 * sh_half:.2f}, {2 * hip_half:.2f} m; no primitive <collision> '
                         'shape on the torso)')
        else:
            # A robot's shoulders can stand well out of its torso (TALOS's do): the torso's
            # own mass says how wide and deep it is; the top row sits a few cm outside it.
            depth, width, ahead = torso
            ry = max(width + TORSO_GAP * s, side_reach + clear)
            rx = max(depth + TORSO_GAP * s, front_reach + abs(ahead) + clear)
            lines.append(f'{"cloth radii":>15}: from the torso\'s inertia (a box '
                         f'{2 * depth:.2f} m deep, {2 * width:.2f} m wide; no primitive '
                         '<collision> shape on the torso) and the legs\' bones')
    rows = 10
    spacing = (top_h - hem_h) / (rows - 1)
    spine_line = P(shape_link) + ((top_h - (P(shape_link) - pelvis) @ up)) * up + ahead * fwd
    center = _in_link(body, shape_link, spine_line)
    shape = {'link': body.name(shape_link), 'center': _r(center), 'radii': _r([rx, ry]),
             'flare': round(0.006 * s, 4), 'opening_deg': 50, 'row_spacing': round(spacing, 4)}
    rpy = _orient(body, shape_link)
    if rpy is not None:
        shape['rpy_deg'] = rpy
    names = {k: body.name(k) for k in range(len(sk.link_names))}
    # M11 references ride the trunk only: a thigh turns 90 degrees when the character sits, and
    # references on it pull the two halves of the hem apart.
    cloth = {'cols': 9, 'rows': rows, 'shape': shape, 'pin_link': body.name(shape_link),
             'reference_bones': list(dict.fromkeys([body.name(shape_link),
                                                    names[body.pelvis]])),
             'max_distance': {'top': round(0.02 * s, 3), 'hem': round(0.40 * s, 3)},
             'bone_column_step': 2}
    sleeves = []
    for side in ('left', 'right'):
        u, f, h = body.arms[side]
        sleeves.append({'link': names[u], 'end_link': names[f], 'twist_share': 0.5})
        if side in body.arm_ends:       # a forearm sleeve to where the link's body ends
            sleeves.append({'link': names[f], 'end': _r(_in_link(body, f, body.arm_ends[side])),
                            'twist_share': 0.5})
        else:
            sleeves.append({'link': names[f], 'end_link': names[h], 'twist_share': 0.5})
    pads = {}
    chest = body.chest
    for side in ('left', 'right'):
        u, f, _ = body.arms[side]
        sign = 1.0 if side == 'left' else -1.0
        at = pelvis + (sh_height - 0.01 * s) * up + sign * 0.43 * sh_half * left
        at += ((P(chest) - pelvis) @ fwd) * fwd
        arm_dir = P(f) - P(u)
        aim = P(u) + arm_dir / np.linalg.norm(arm_dir) * min(0.1 * s,
                                                             0.4 * np.linalg.norm(arm_dir))
        pads[side] = {'pivot': _r(_in_link(body, chest, at)), 'aim_link': names[u],
                      'aim': _r(_in_link(body, u, aim)), 'length': round(0.65 * sh_half, 3),
                      'below_length': round(0.4 * sh_height, 3)}
    upper = {'link': names[chest], 'shoulder_pads': pads, 'skin_radius': round(0.3 * s, 3)}
    rpy = _orient(body, chest)
    if rpy is not None:
        upper['rpy_deg'] = rpy
    neck = body.neck
    neck_at = P(neck)
    if (neck_at - P(body.chest)) @ up < SAME_PLACE:
        # A head fixed to the torso with its frame at or below the torso's (a robot's): the
        # neck is at the shoulders' height under the head's centre of mass.
        top = body.tips[neck]
        neck_at = top - ((top - pelvis) @ up - sh_height) * up
    hood = {'link': names[neck],
            'pivot': _r(_in_link(body, neck, neck_at - 0.09 * s * fwd + 0.05 * s * up)),
            'length': round(0.2 * s, 3),
            'rest_direction': _r(_dir_in_link(body, neck, -0.45 * fwd - 0.9 * up))}
    rig = {}
    if not np.allclose(up, [0, 0, 1], atol=1e-3) or not np.allclose(fwd, [1, 0, 0], atol=1e-3):
        rig['up'] = _r(up)
        rig['forward'] = _r(fwd)
    rig.update({'cloth': cloth, 'jacket_bones': {'sleeves': sleeves, 'upper': upper},
                'hood': hood})
    # The floor is square to the world's up (REP 103's +z), never to the body's (issue 47
    # item 1).
    rig['colliders'], why = _colliders(body, shape_link, top_h, rx, ry, s, ahead,
                                       np.array(REP103_UP))
    lines.append(f'{"colliders":>15}: {why}')
    return _plain(rig), lines, body


def _colliders(body, shape_link, top_h, rx, ry, s, ahead, world_up):
    """Return colliders: the URDF's shapes on pelvis, torso and thighs if all have some.

    With the shapes, the links carrying the other leg bones the jacket hangs over add theirs,
    and a leg bone their shapes leave bare or far thinner than a bone collider gets a capsule
    (issue 35: the minimal cylinders of a robot cover half a thigh). The
    floor is square to ``world_up``.
    """
    shapes = urdf_shapes(body.skeleton.urdf_xml)
    wanted = [body.pelvis, shape_link, body.chest, body.thighs['left'], body.thighs['right']]
    wanted = list(dict.fromkeys(wanted))
    floor = {'name': 'floor', 'type': 'plane', 'link': 'world', 'point': [0.0, 0.0, 0.0],
             'normal': _r(world_up)}
    radius = round(BONE_COLLIDER_SHARE * body.height, 3)
    if all(body.name(k) in shapes for k in wanted):
        # The torso's shapes hold its bones; the legs' are checked.
        bones = [b for b in _hung_over_bones(body) if b[1] not in body.spine]
        wanted += [k for _, k, _, _ in bones if body.name(k) in shapes and k not in wanted]
        # The feet's too: a foot brought up to the hem (crawling, getting up) went through it.
        feet = [body.ankles[side] for side in ('left', 'right') if side in body.ankles]
        wanted += [k for k in _below(body, feet[::-1])
                   if body.name(k) in shapes and k not in wanted]
        bare = [b for b in bones if not _covered(body, shapes, wanted, b[2], b[3], radius / 2)]
        names = [body.name(k) for k in wanted]
        why = 'from the URDF <collision> shapes of ' + ', '.join(names)
        if bare:
            why += '; a capsule over ' + ', '.join(b[0] for b in bare) + ' (bare or thin)'
        return {'from_urdf': names, 'add': [_bone_capsule(body, b, radius) for b in bare]
                + [floor]}, why
    P, up = body.pos, body.up
    pelvis = P(body.pelvis)
    torso_c = pelvis + (top_h - 0.02 * s) * up + ((P(shape_link) - pelvis) @ body.forward
                                                  + ahead) * body.forward
    # The torso thinner than the flesh: when the character sits bent forward, colliders the
    # size of the body meet and leave the front of the jacket no room outside them all.
    out = [_ellipsoid(body, 'torso', shape_link, torso_c, [0.8 * (rx - 0.02 * s),
                                                           ry - 0.02 * s, 0.22 * s]),
           _ellipsoid(body, 'pelvis', body.pelvis, pelvis - 0.03 * s * up,
                      [0.13 * s, 0.9 * ry, 0.14 * s])]
    out += [_bone_capsule(body, bone, radius) for bone in _hung_over_bones(body)]
    out.append(floor)
    return out, ('an ellipsoid on the torso and the pelvis, a capsule over each spine and leg '
                 'bone down to the ankles, across the hips and to each frame fixed in the '
                 'pelvis (no primitive '
                 '<collision> shape on ' + ', '.join(
                     body.name(k) for k in wanted if body.name(k) not in shapes) + ')')


def _below(body, links):
    """Return ``links`` and every link under them (a foot: the ankle's ball joint's links)."""
    parent = body.skeleton.parent
    out, todo = [], list(links)
    while todo:
        k = todo.pop()
        out.append(k)
        todo += [int(c) for c in np.flatnonzero(parent == k)]
    return out


def _bone_capsule(body, bone, radius):
    """Return a capsule collider over a bone of ``_hung_over_bones``, on the link carrying it."""
    name, link, a, b = bone
    return {'name': name, 'type': 'capsule', 'link': body.name(link),
            'a': _r(_in_link(body, link, a)), 'b': _r(_in_link(body, link, b)), 'radius': radius}


def _covered(body, shapes, links, a, b, depth):
    """Tell whether the links' shapes hold the bone a-b (root frame) at least ``depth`` deep.

    Sampled between its ends, which the neighbouring bones' shapes hold.
    """
    for t in (0.1, 0.3, 0.5, 0.7, 0.9):
        p = a + t * (b - a)
        if not any(_deep_inside(s.as_collider(''), _in_link(body, k, p), depth)
                   for k in links for s in shapes.get(body.name(k), [])):
            return False
    return True


def _deep_inside(entry, p, depth):
    """Tell whether a point (the collider's link frame) is ``depth`` inside a collider entry."""
    if entry['type'] == 'capsule':
        a, b = np.asarray(entry['a']), np.asarray(entry['b'])
        ab = b - a
        t = np.clip((p - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        return float(np.linalg.norm(p - a - t * ab)) <= entry['radius'] - depth
    shrunk = np.asarray(entry['radii']) - depth
    if (shrunk <= 0).any():
        return False
    q = rpy_matrix(np.radians(entry['rpy_deg'])).T @ (p - np.asarray(entry['center']))
    return float(np.linalg.norm(q / shrunk)) <= 1.0


def _chain(body, end):
    """Return the links from the pelvis down to ``end``, each the parent of the next."""
    out, k = [], end
    while k >= 0 and k != body.pelvis:
        out.append(k)
        k = body.skeleton.parent[k]
    return [body.pelvis] + out[::-1]


def _hung_over_bones(body):
    """Return the bones the jacket hangs over: (name, link carrying it, start, end), root frame.

    The spine's from the pelvis to the chest, and each leg's from the pelvis to the ankle, the
    shin too (a knee lifted in a stride or a seated shin meets the hem), one across the hips
    where the legs' hip bones leave the pelvis, and the pelvis's other bones
    (``_pelvis_frame_bones``). A bone shorter than a bone collider's radius is left to its
    neighbours' rounded ends.
    """
    shortest = BONE_COLLIDER_SHARE * body.height
    out = _pelvis_frame_bones(body, shortest)
    chains = [('spine', 'spine', body.chest)] + [(side[0], side, body.ankles[side])
                                                 for side in ('left', 'right')]
    hips = {}
    for prefix, side, end in chains:
        links = _chain(body, end)
        phase, counts = ('spine' if side == 'spine' else 'hip'), {}
        for parent, child in zip(links, links[1:]):
            if parent == body.thighs.get(side):
                phase = 'thigh'
            a, b = body.pos(parent), body.pos(child)
            if phase == 'thigh' and np.linalg.norm(a - body.knees[side]) < SAME_PLACE:
                phase = 'shin'
            if np.linalg.norm(b - a) < shortest:
                continue
            if phase == 'hip':
                hips[side] = b
            counts[phase] = counts.get(phase, 0) + 1
            name = phase if side == 'spine' else f'{prefix}_{phase}'
            out.append((name + (f'_{counts[phase]}' if counts[phase] > 1 else ''), parent, a, b))
    # Hip bones from the pelvis form a V the hem's middle was pushed up into between the legs
    # (TALOS raising its arms): a bone across the hips closes it.
    if len(hips) == 2 and np.linalg.norm(hips['left'] - hips['right']) >= shortest:
        out.append(('hips', body.pelvis, hips['left'], hips['right']))
    return out


def _pelvis_frame_bones(body, shortest):
    """Return the pelvis's bones to its other children (a sensor's frame), ending above the knees.

    Such a frame sits in the pelvis's flesh (Romeo's IMU, low and ahead of its spine): the body
    proxy (core.body_proxy) draws a bone to it on a pelvis without shapes, so the cloth must
    stay out of it too. Frames at one place give one bone.
    """
    sk, pelvis = body.skeleton, body.pelvis
    chains = set(body.spine) | {k for side in ('left', 'right')
                                for k in _chain(body, body.ankles[side])}
    lowest = min((body.knees[side] - body.pos(pelvis)) @ body.up for side in ('left', 'right'))
    out, ends = [], []
    for child in np.flatnonzero(sk.parent == pelvis):
        a, b = body.pos(pelvis), body.pos(int(child))
        if (child in chains or np.linalg.norm(b - a) < shortest or (b - a) @ body.up <= lowest
                or any(np.linalg.norm(b - e) < SAME_PLACE for e in ends)):
            continue
        ends.append(b)
        out.append(('pelvis' + (f'_{len(out) + 1}' if out else ''), pelvis, a, b))
    return out


def _inertia_torso(body, shape_link):
    """Return the torso's half-depth and half-width, and how far ahead of the spine it is.

    Each spine link above the pelvis with a mass is the uniform box of its inertia, its sides
    along forward, left and up (from the moments about those axes); None when no link gives
    one at least a tenth of the height. A box over half the height is a placeholder inertia.
    """
    frames, centre = body.frames, body.pos(shape_link)
    if frames is None or frames.inertia is None:
        return None
    axes = _body_frame(body)
    boxes = []
    for k in body.spine[1:]:
        mass = frames.mass[k]
        if mass <= 0:
            continue
        rotation = body.rest[k][:3, :3]
        moments = np.diag(axes.T @ rotation @ frames.inertia[k] @ rotation.T @ axes)
        sides = np.sqrt(np.clip(6 * (moments.sum() - 2 * moments) / mass, 0.0, None))
        if np.isfinite(sides).all() and 0.1 * body.height <= sides.max() <= 0.5 * body.height:
            com = rotation @ frames.com[k] + body.pos(k) - centre
            boxes.append((mass, com @ body.forward, sides[0] / 2, abs(com @ body.left)
                          + sides[1] / 2))
    if not boxes:
        return None
    ahead = max(boxes)[1]                   # the heaviest box's centre: the torso's
    depth = max(abs(at - ahead) + half for _, at, half, _ in boxes)
    return depth, max(b[3] for b in boxes), ahead


def _leg_reach(body):
    """Return how far the leg bones above the knees reach from the pelvis, sideways and ahead."""
    pelvis = body.pos(body.pelvis)
    points = [body.pos(k) for side in ('left', 'right') for k in _chain(body, body.ankles[side])
              if (body.pos(k) - pelvis) @ body.up >= (body.knees[side] - pelvis) @ body.up]
    points += [body.knees[side] for side in ('left', 'right')]
    d = np.array(points) - pelvis
    return float(np.abs(d @ body.left).max()), float(np.abs(d @ body.forward).max())


def _ellipsoid(body, name, link, center, radii):
    e = {'name': name, 'link': body.name(link), 'center': _r(_in_link(body, link, center)),
         'radii': _r(radii)}
    rpy = _orient(body, link)
    if rpy is not None:
        e['rpy_deg'] = rpy
    return e


HEADER = """\
# A jacket rig proposed by `jacket_cloth rig` for {urdf} ({links} links, {height:.2f} m tall).
# Positions are metres in the named link's frame at the URDF's zero pose; angles in degrees.
# Tune it: every key is explained in docs/your_character.md. What was chosen:
{choices}
"""

COMMENTS = {
    'up': '# the character\'s up and forward in the URDF root frame (its links are not Z-up)',
    'cloth': '# M3: a coarse grid around the torso; the top row is pinned (M6)',
    'jacket_bones': '# M1 sleeves on the arms, M2 shoulder pads on the chest',
    'hood': '# M8: a one-particle pendulum behind the neck',
    'world_up': "# the world's up where the motion lives (gravity, the floor); default [0, 0, 1]",
    'colliders': '# M10: the body the cloth must stay out of, and the floor',
}


def _plain(value):
    """Return the value with numbers as Python floats, for yaml.safe_dump."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def to_yaml(rig: dict, lines: list[str], urdf: str, body: Body) -> str:
    """Return the rig as commented YAML a user can tune.

    :param rig: the rig, as ``propose`` returned it.
    :param lines: what was chosen and why, for the header.
    :param urdf: the URDF's path, as the header names it.
    :param body: the body found, for the header's link count and height.
    """
    head = HEADER.format(urdf=urdf, links=len(body.skeleton.link_names), height=body.height,
                         choices='\n'.join('#   ' + line.strip() for line in lines))
    parts = [head]
    for key, value in _plain(rig).items():
        if key == 'forward':
            continue
        if key in COMMENTS:
            parts.append('\n' + COMMENTS[key] + '\n')
        chunk = {key: value}
        if key == 'up':
            chunk['forward'] = rig['forward']
        parts.append(yaml.safe_dump(chunk, sort_keys=False, default_flow_style=None, width=99))
    return ''.join(parts)
