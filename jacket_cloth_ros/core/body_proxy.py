# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A body the measures see, apart from the rig's colliders (issue 35 item 4).

Every link's primitive ``<collision>`` shapes (urdf_colliders: a sphere or a box an ellipsoid,
a cylinder or a ``<capsule>`` a capsule) and, for a link without one (meshes only, or none), a
capsule along each of its bones (from the link to each child that is somewhere else), its
radius a share of the skeleton's size. Links under the sleeves are left out: the jacket's body
hangs between them and the torso. Depths are measured with measures.depth_inside, on the
bundles.Colliders this proxy is posed into, so they do not depend on the rig's own colliders.
"""

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .bundles import Colliders
from .config import ConfigError
from .transforms import rpy_matrix
from .urdf_colliders import collider_name, urdf_shapes

if TYPE_CHECKING:           # for the annotations only
    from .rig import Rig
    from .skeleton import Skeleton

# A bone capsule's radius as a share of the skeleton's size (its zero pose's largest extent):
# about a knee's for a person, thinner than a thigh or a trunk: a depth is the body's.
BONE_RADIUS_SHARE = 0.03


@dataclass(frozen=True)
class BodyProxy:
    """Ellipsoids and capsules on links, in the links' frames, with the link each one is on."""

    ellipsoid_link: np.ndarray      # (E,) link indices
    center: np.ndarray              # (E,3)
    rotation: np.ndarray            # (E,3,3) axes as columns
    radii: np.ndarray               # (E,3)
    capsule_link: np.ndarray        # (K,)
    capsule_a: np.ndarray           # (K,3)
    capsule_b: np.ndarray           # (K,3)
    capsule_radius: np.ndarray      # (K,)
    labels: list                    # E + K link names, ellipsoids first

    def posed(self, links: np.ndarray) -> Colliders:
        """Return the proxy at a skeleton pose, as measures.depth_inside takes it.

        :param links: the link transforms (L, 4, 4) in the frame the depths are wanted in.
        :returns: its ellipsoids and capsules posed, no planes.
        """
        t = links[self.ellipsoid_link]
        centers = np.einsum('kij,kj->ki', t[:, :3, :3], self.center) + t[:, :3, 3]
        axes = np.einsum('kij,kjl->kil', t[:, :3, :3], self.rotation)
        c = links[self.capsule_link]
        a = np.einsum('kij,kj->ki', c[:, :3, :3], self.capsule_a) + c[:, :3, 3]
        b = np.einsum('kij,kj->ki', c[:, :3, :3], self.capsule_b) + c[:, :3, 3]
        none = np.zeros((0, 3))
        return Colliders(centers.reshape(-1, 3), axes.reshape(-1, 3, 3), self.radii, a, b,
                         self.capsule_radius, none, none)


def sleeved_links(rig: 'Rig') -> list[int]:
    """Return the links a rig's M1 sleeves ride on: the body proxy leaves them out.

    :param rig: the rig.
    :returns: link indices; none without a ``jacket_bones`` section.
    """
    return [s.link for s in rig.layer.sleeves] if rig.layer is not None else []


def body_proxy(skeleton: 'Skeleton', leave_out: Sequence[int] = ()) -> BodyProxy:
    """Return the body proxy of ``skeleton``.

    :param skeleton: the URDF skeleton, its ``<collision>`` shapes read from its text.
    :param leave_out: link indices left out with every link below them (the sleeved arms).
    """
    rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    names = list(skeleton.link_names)
    out_of_it = {int(k) for k in leave_out}
    for k in range(len(names)):         # parents come before their children
        if skeleton.parent[k] in out_of_it:
            out_of_it.add(k)
    origins = rest[:, :3, 3]
    radius = BONE_RADIUS_SHARE * float((origins.max(axis=0) - origins.min(axis=0)).max())
    shapes = urdf_shapes(skeleton.urdf_xml)
    ell, caps = [], []
    for k, name in enumerate(names):
        if k in out_of_it:
            continue
        mine = shapes.get(name, [])
        for j, shape in enumerate(mine):
            entry = shape.as_collider(collider_name(name, j, len(mine)))
            if entry['type'] == 'ellipsoid':
                ell.append((k, entry['center'], rpy_matrix(np.radians(entry['rpy_deg'])),
                            entry['radii'], name))
            else:
                caps.append((k, entry['a'], entry['b'], entry['radius'], name))
        if mine or (k == 0 and getattr(skeleton, 'world_root', False)):
            continue                # a massless fixed root is the world, not a bone
        for child in np.flatnonzero(skeleton.parent == k):
            if child in out_of_it:
                continue
            end = np.linalg.solve(rest[k], rest[child][:, 3])[:3]
            if np.linalg.norm(end) > 1e-6:
                caps.append((k, np.zeros(3), end, radius, name))
    return BodyProxy(
        np.array([e[0] for e in ell], dtype=np.int64), np.array([e[1] for e in ell],
                                                                dtype=float).reshape(-1, 3),
        np.array([e[2] for e in ell], dtype=float).reshape(-1, 3, 3),
        np.array([e[3] for e in ell], dtype=float).reshape(-1, 3),
        np.array([c[0] for c in caps], dtype=np.int64),
        np.array([c[1] for c in caps], dtype=float).reshape(-1, 3),
        np.array([c[2] for c in caps], dtype=float).reshape(-1, 3),
        np.array([c[3] for c in caps], dtype=float), [e[4] for e in ell] + [c[4] for c in caps])


def lowest_reach(skeleton: 'Skeleton', rest: np.ndarray, up: np.ndarray) -> float:
    """Return how far down ``up`` the body reaches at a pose: the soles, as its shapes say.

    Its collision shapes, else capsules on its bones (:func:`body_proxy`), else (or where the
    shapes' reader refuses them) its links: what stands a character on the floor, the
    retargeted clips and a pose sent without its world pose alike.

    :param skeleton: the character.
    :param rest: (L,4,4) its links at the pose, in the root's frame.
    :param up: (3,) the world's up, unit.
    """
    low = [float((rest[:, :3, 3] @ up).min())]
    proxy = _proxy_of(skeleton)
    if proxy is None:
        # Shapes the URDF's own parser loads but their reader refuses only refine where the
        # soles are: the link origins stand in, and nothing that stands a body fails on them.
        return low[0]
    shapes = proxy.posed(rest)
    if len(shapes.centers):
        reach = np.linalg.norm(np.einsum('kij,i->kj', shapes.axes, up) * shapes.radii, axis=1)
        low.append(float((shapes.centers @ up - reach).min()))
    if len(shapes.capsule_a):
        ends = np.minimum(shapes.capsule_a @ up, shapes.capsule_b @ up)
        low.append(float((ends - shapes.capsule_radii).min()))
    return min(low)


@functools.lru_cache(maxsize=16)
def _proxy_of(skeleton: 'Skeleton') -> 'BodyProxy | None':
    """body_proxy of the whole body once per character (it reads the URDF's shapes anew).

    None where the shapes' reader refuses them.
    """
    try:
        return body_proxy(skeleton)
    except ConfigError:
        return None
