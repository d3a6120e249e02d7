# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The built-in clips on any skeleton, through the rig's roles (``motion --clip C --urdf X``).

The shipped character plays the clip; each of its body parts found by the rig proposal
(``rigging.propose.find_body``: pelvis, chest, neck, upper arms, forearms, thighs, shins) gives
a direction or a frame in the body's own axes (forward, left, up), and the other skeleton's
joints are solved, chain by chain, to point its same parts the same way. Its pelvis takes the
shipped pelvis's frame in the world, so any description (Z-up or Y-up, a robot or a captured
skeleton) stands upright in a Z-up world (REP 103); the root's travel and height are scaled by
the legs' lengths. No ROS.
"""

import xml.etree.ElementTree as ET

import numpy as np

from ..core.body_proxy import lowest_reach
from ..core.skeleton import Skeleton, load_shipped_character
from ..core.transforms import matrix_to_quat, quat_to_matrix
from ..rigging.propose import find_body
from .clips import clip_joints, looped_pose

# Damped least squares per chain, each step damped by this (rad^2).
DAMPING = 1e-4
# Each joint is also pulled towards its zero pose with this weight (per rad, against unit
# directions): a twist the parts do not see (a straight leg's hip yaw) stays near zero instead
# of wandering to its limit, where the knee then bends the wrong way.
REST_WEIGHT = 0.03
# A chain's solve stops after this many rounds, or once its error moves by less than this.
ROUNDS = 12
SETTLED = 1e-6
# Finite-difference step of a joint (rad or m).
STEP = 1e-5


# A joint the clips move acts as the shipped character's when its axis and its place, seen
# from the root at the zero pose, point within these of that joint's (deg): a robot that only
# shares some names (iCub's arms) turns its joints about other axes or faces another way.
SAME_AXIS_DEG = 10.0
SAME_PLACE_DEG = 20.0
# ... and lies within this share of that joint's distance from the root: a skeleton of
# another size would stand the clip's root height in the air or in the floor.
SAME_DISTANCE_SHARE = 0.1


def unlike_the_clips_character(skeleton: Skeleton, clip: str) -> str:
    """Say how a skeleton differs from the character a clip is made for; '' if it does not.

    A clip gives the shipped character's joint values and world pose: played as it is, it
    moves another skeleton right only if that has each joint it moves, turning about the
    same axis at the same place (a derivative of the shipped character, or that one itself).

    :param skeleton: the skeleton the clip is to move.
    :param clip: a name of ``clips.ALL_CLIPS``.
    """
    joints = clip_joints(clip)
    moves = f'the clip {clip!r} moves'
    missing = sorted(joints - set(skeleton.joint_names))
    if len(missing) == len(joints):
        return f'has none of the {len(joints)} joints {moves}'
    if missing:
        return (f'lacks {len(missing)} of the {len(joints)} joints ({", ".join(missing[:5])}) '
                f'{moves}')
    shipped = load_shipped_character()
    rests = [(s, s.forward(np.zeros(len(s.joint_names)))) for s in (shipped, skeleton)]
    for name in sorted(joints):
        ours, theirs = (_joint_at_rest(s, links, name) for s, links in rests)
        for k, (what, most) in enumerate((('turns about another axis', SAME_AXIS_DEG),
                                          ('sits another way from its root', SAME_PLACE_DEG))):
            a, b = ours[k], theirs[k]
            if np.linalg.norm(a) < 1e-9 or np.linalg.norm(b) < 1e-9:
                continue
            if np.degrees(np.arccos(np.clip(_unit(a) @ _unit(b), -1.0, 1.0))) > most:
                return (f'names the joints {moves}, but its {name} {what} than the shipped '
                        'character\'s')
        far, ours_far = np.linalg.norm(theirs[1]), np.linalg.norm(ours[1])
        if abs(far - ours_far) > SAME_DISTANCE_SHARE * ours_far:
            return (f'names the joints {moves}, but its {name} is {far:.2f} m from its root, '
                    f'the shipped character\'s {ours_far:.2f} m')
    return ''


def _joint_at_rest(skeleton, links, name):
    """Return a joint's axis and its place, in the root's frame at the zero pose ``links``."""
    # The link the joint itself moves: a mimic joint shares its value, not its axis.
    k = next(k for k, link in enumerate(skeleton.link_names)
             if skeleton.joint_of_link.get(link) == name)
    return links[k][:3, :3] @ skeleton.axis[k], links[k][:3, 3]


class _Roles:
    """A skeleton's body parts and its body axes in the pelvis, chest and neck links."""

    def __init__(self, skeleton):
        body = find_body(skeleton)
        self.skeleton, self.body = skeleton, body
        rest = body.rest
        frame = np.column_stack([body.forward, body.left, body.up])
        self.pelvis, self.chest, self.neck = body.pelvis, body.chest, body.neck
        # The body's axes seen from each link, so a posed link gives them back.
        self.axes = {k: rest[k][:3, :3].T @ frame for k in (body.pelvis, body.chest, body.neck)}
        self.arms = {s: body.arms[s] for s in ('left', 'right')}
        # An arm that ends at the elbow ends at a point of its forearm link, in that link.
        self.arm_ends = {s: rest[body.arms[s][1]][:3, :3].T @ (p - rest[body.arms[s][1]][:3, 3])
                         for s, p in body.arm_ends.items()}
        self.legs = {s: (body.thighs[s], _link_at(body, body.thighs[s], body.ankles[s],
                                                  body.knees[s]), body.ankles[s])
                     for s in ('left', 'right')}
        pts = rest[:, :3, 3]
        self.stand = float(pts[body.pelvis] @ body.up) - lowest_reach(skeleton, rest, body.up)
        thigh, knee, ankle = (pts[k] for k in self.legs['left'])
        self.leg = float(np.linalg.norm(knee - thigh) + np.linalg.norm(ankle - knee))

    def frame(self, links, link):
        """Return the body's axes (columns) as ``link`` carries them, in the root frame."""
        return links[link][:3, :3] @ self.axes[link]

    def part(self, links, name):
        """Return one part's pose in the body's own axes: what the other skeleton copies.

        The chest's frame in the pelvis's and the neck's in the chest's (3,3); an arm's upper
        arm and forearm directions in the chest's axes, a leg's thigh and shin in the pelvis's.
        """
        if name == 'chest':
            return self.frame(links, self.pelvis).T @ self.frame(links, self.chest)
        if name == 'neck':
            return self.frame(links, self.chest).T @ self.frame(links, self.neck)
        side, limb = name.split()
        if limb == 'arm':
            seen, (a, b, c) = self.frame(links, self.chest), self.arms[side]
        else:
            seen, (a, b, c) = self.frame(links, self.pelvis), self.legs[side]
        ends = [links[k][:3, 3] for k in (a, b, c)]
        if limb == 'arm' and side in self.arm_ends:
            ends[2] = links[b][:3, :3] @ self.arm_ends[side] + links[b][:3, 3]
        return np.concatenate([_unit(seen.T @ (ends[j] - ends[i]))
                               for i, j in ((0, 1), (1, 2))]).reshape(2, 3)


class Retarget:
    """The shipped clips on another skeleton; its poses continue from one call to the next.

    :param target: the skeleton to move.
    :param source: the skeleton the clips are written for (default: the shipped character).
    """

    def __init__(self, target: Skeleton, source: Skeleton | None = None):
        self.source = _Roles(source if source is not None else load_shipped_character())
        self.target = _Roles(target)
        self.skeleton = target
        self.scale = self.target.leg / self.source.leg
        low, high = _limits(target)
        self.low, self.high = low, high
        self.q = np.clip(np.zeros(len(target.joint_names)), low, high)
        t, r = self.target, target
        # Each part's chain: the joints between the link it hangs from and its end.
        self.chains = [('chest', _joints(r, t.pelvis, t.chest))]
        self.chains.append(('neck', _joints(r, t.chest, t.neck)))
        for side in ('left', 'right'):
            self.chains.append((side + ' arm', _joints(r, t.chest, t.arms[side][2])))
            self.chains.append((side + ' leg', _joints(r, t.pelvis, t.legs[side][2])))

    def roles(self) -> str:
        """Return the target's links each part is read from, as one line names them."""
        t, name = self.target, self.skeleton.link_names
        parts = [f'pelvis {name[t.pelvis]}', f'chest {name[t.chest]}', f'neck {name[t.neck]}']
        for side in ('left', 'right'):
            upper, fore, _ = t.arms[side]
            thigh, shin, _ = t.legs[side]
            parts.append(f'{side} arm {name[upper]}, {name[fore]}')
            parts.append(f'{side} leg {name[thigh]}, {name[shin]}')
        return '; '.join(parts)

    def pose(self, clip: str, t: float) -> tuple[np.ndarray, tuple[float, ...]]:
        """Return the target's joint values and its root's world pose at ``t`` of ``clip``.

        :param clip: a name of ``clips.ALL_CLIPS``.
        :param t: seconds from the clip's start; past its end the clip continues from where
            its last loop ended (``clips.looped_pose``).
        :returns: (joint values in ``joint_names``' order, root x, y, z, qx, qy, qz, qw).
        """
        src = self.source
        values, root = looped_pose(clip, t)
        q_src = np.array([values.get(j, 0.0) for j in src.skeleton.joint_names])
        links = src.skeleton.forward(q_src)
        for part, joints in self.chains:
            self._solve(part, joints, src.part(links, part))
        # The pelvis's world frame: the shipped pelvis's axes, its travel scaled to the legs.
        world = np.eye(4)
        world[:3, :3] = quat_to_matrix(np.asarray(root[3:], float))
        world[:3, 3] = root[:3]
        axes = world[:3, :3] @ src.frame(links, src.pelvis)
        at = world[:3, :3] @ links[src.pelvis][:3, 3] + world[:3, 3]
        tgt = self.target
        place = np.array([at[0] * self.scale, at[1] * self.scale,
                          tgt.stand + (at[2] - src.stand) * self.scale])
        mine = self.skeleton.forward(self.q)
        pelvis = np.eye(4)
        pelvis[:3, :3] = axes @ tgt.axes[tgt.pelvis].T
        pelvis[:3, 3] = place
        root_pose = pelvis @ np.linalg.inv(mine[tgt.pelvis])
        quat = matrix_to_quat(root_pose[:3, :3])
        return self.q.copy(), tuple(float(v) for v in (*root_pose[:3, 3], *quat))

    def _solve(self, part, joints, wanted):
        """Move ``joints`` (damped least squares, within their limits) towards ``wanted``."""
        if not len(joints):
            return
        q = self.q
        error = self._error(part, q, joints, wanted)
        rest = REST_WEIGHT * np.eye(len(joints))
        for _ in range(ROUNDS):
            jac = np.empty((len(error), len(joints)))
            for c, j in enumerate(joints):
                saved = q[j]
                q[j] = saved + STEP
                jac[:, c] = (self._error(part, q, joints, wanted) - error) / STEP
                q[j] = saved
            jac[-len(joints):] = rest        # exact: the pull is linear
            step = np.linalg.solve(jac.T @ jac + DAMPING * np.eye(len(joints)), -jac.T @ error)
            q[joints] = np.clip(q[joints] + step, self.low[joints], self.high[joints])
            new = self._error(part, q, joints, wanted)
            settled = abs(error @ error - new @ new) < SETTLED
            error = new
            if settled:
                break

    def _error(self, part, q, joints, wanted):
        got = self.target.part(self.skeleton.forward(q), part)
        return np.concatenate([(got - wanted).ravel(), REST_WEIGHT * q[joints]])

    def content(self, clip: str, t: float,
                world_joint: str = 'world_joint') -> tuple[list[str], list[float]]:
        """(names, positions) of a JointState of the target at ``t``: every joint, the root.

        :param clip: a name of ``clips.ALL_CLIPS``.
        :param t: seconds from the clip's start.
        :param world_joint: the prefix of the root's variables (``world_joint/trans_x`` ...).
        """
        from ..core.inputs import WORLD_VARIABLES
        q, root = self.pose(clip, t)
        names = list(self.skeleton.joint_names) + [f'{world_joint}/{v}'
                                                   for v in WORLD_VARIABLES]
        return names, [float(v) for v in q] + list(root)


def _unit(v):
    n = np.linalg.norm(v)
    return v / n if n > 1e-12 else v


def _link_at(body, top, end, where):
    """Return the link between ``top`` and ``end`` (its ancestor) that sits at ``where``."""
    parent = body.skeleton.parent
    path, k = [], end
    while k >= 0 and k != top:
        path.append(k)
        k = int(parent[k])
    return min(path, key=lambda c: (np.linalg.norm(body.rest[c][:3, 3] - where), -c))


def _joints(skeleton, top, end):
    """Return the joint variables that move ``end`` relative to ``top`` (its ancestor)."""
    out, k = [], end
    while k >= 0 and k != top:
        if skeleton.var[k] >= 0 and skeleton.kind[k] == 0:
            out.append(int(skeleton.var[k]))
        k = int(skeleton.parent[k])
    return np.array(sorted(set(out)), dtype=np.int64)


def _limits(skeleton):
    """Return each joint's lower and upper limit from the URDF (none: unbounded)."""
    n = len(skeleton.joint_names)
    low, high = np.full(n, -np.inf), np.full(n, np.inf)
    try:
        root = ET.fromstring(skeleton.urdf_xml.rstrip('\0 \r\n\t').lstrip()
                             .split('?>', 1)[-1] if skeleton.urdf_xml.lstrip().startswith('<?')
                             else skeleton.urdf_xml.rstrip('\0 \r\n\t'))
    except ET.ParseError:
        return low, high
    for joint in root.iter('joint'):
        k = skeleton.joint_index.get(joint.get('name'))
        limit = joint.find('limit')
        if k is None or joint.get('type') not in ('revolute', 'prismatic') or limit is None:
            continue
        try:
            lo, hi = float(limit.get('lower', 0.0)), float(limit.get('upper', 0.0))
        except ValueError:
            continue
        if lo < hi:                   # a joint without a range is left free
            low[k], high[k] = lo, hi
    return low, high
