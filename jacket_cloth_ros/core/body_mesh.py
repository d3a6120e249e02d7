# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A simple body for the jacket to sit on, where the character's URDF has no visuals of its own.

Made of what the cloth already knows of the body: the rig's M10 ellipsoids and capsules, then a
capsule along every skeleton segment they leave bare (arms, neck, feet) and a head on the hood's
link's child. Each piece rides rigidly on one link (body_shapes): live markers send them as
spheres and cylinders, which a viewer shades itself; pictures and export mesh them
(body_mesh), a mesh of the same kind as the jacket's (jacket_mesh.SkinnedMesh).
"""

from typing import TYPE_CHECKING

import numpy as np

from .bundles import ColliderModel, floats, ints
from .jacket_mesh import BODY, MeshBuilder, inverse
from .transforms import apply_transform

if TYPE_CHECKING:           # for the annotations only
    from .jacket_mesh import SkinnedMesh
    from .rig import Rig
    from .skeleton import Skeleton

SIDES, BANDS = 8, 4         # round an ellipsoid or capsule, and from pole to pole


def body_shapes(skeleton: 'Skeleton', rig: 'Rig') -> ColliderModel:
    """Return the body's pieces, each in its link's frame: ellipsoids and capsules.

    The rig's colliders, a capsule along every segment they leave bare, and a head (the last
    ellipsoid). Live markers draw these as spheres and cylinders; :func:`body_mesh` meshes them.

    :param skeleton: the character.
    :param rig: its rig (colliders, the hood's link for the head, the body's up).
    """
    rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    covered = set(int(k) for k in rig.collider_links) | set(int(k) for k in rig.capsule_links)
    size = max(rig.height_m, 0.3)
    limb = float(np.clip(0.024 * size, 0.01, 0.06))
    cap_links, cap_ends = list(rig.capsule_links), list(rig.capsule_ends)
    cap_radii = list(rig.capsule_radii)
    # Where each link's segment starts: its parent's origin, or further up a chain of segments
    # too short to draw alone (a wrist's sensor and tool frames), so the chain is drawn as
    # one piece and a hand does not float off its forearm.
    start = list(range(len(skeleton.link_names)))
    for child in range(1, len(skeleton.link_names)):
        parent = int(skeleton.parent[child])
        if parent in covered:
            continue
        a, c = rest[start[parent]][:3, 3], rest[child][:3, 3]
        if np.linalg.norm(c - a) < 0.04 * size:
            start[child] = start[parent]
            continue
        cap_links.append(parent)
        cap_ends.append(_local(rest[parent], np.array([a, c])))
        cap_radii.append(limb)
    head_link = rig.hood.link
    heads = [k for k in range(len(skeleton.link_names)) if skeleton.parent[k] == head_link]
    top = heads[0] if heads else head_link
    r = 0.065 * size
    up = rig.world_axes[:, 2]
    centre = rest[top][:3, 3] + up * 0.7 * r
    # A head link whose origin sits in the torso (a robot's, fixed at the waist) would bury
    # the head: it stays above the hood's pivot, which the rig puts behind the neck.
    pivot = apply_transform(rest[head_link], rig.hood.pivot[None])[0]
    centre = centre + up * max(0.0, r - float((centre - pivot) @ up))
    links = list(rig.collider_links) + [top]
    centres = list(rig.collider_centers) + [_local(rest[top], centre[None])[0]]
    rotations = list(rig.collider_rotations) + [rest[top][:3, :3].T @ rig.world_axes]
    radii = list(rig.collider_radii) + [np.array([0.9 * r, 0.8 * r, r])]
    return ColliderModel(
        ints(links), floats(np.reshape(centres, (-1, 3))),
        floats(np.reshape(rotations, (-1, 3, 3))), floats(np.reshape(radii, (-1, 3))),
        ints(cap_links), floats(np.reshape(cap_ends, (-1, 2, 3))), floats(cap_radii),
        ints(np.zeros(0)), floats(np.zeros((0, 3))), floats(np.zeros((0, 3))))


def body_mesh(skeleton: 'Skeleton', rig: 'Rig',
              shapes: ColliderModel | None = None) -> 'SkinnedMesh':
    """Build the body's mesh from :func:`body_shapes`; its joints are the skeleton's links.

    :param skeleton: the character.
    :param rig: its rig.
    :param shapes: its body_shapes, when already made.
    """
    rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    shapes = body_shapes(skeleton, rig) if shapes is None else shapes
    b = MeshBuilder()
    for link, centre, rotation, radii in zip(shapes.links, shapes.centers, shapes.rotations,
                                             shapes.radii):
        _ellipsoid(b, link, apply_transform(rest[link], centre[None])[0],
                   rest[link][:3, :3] @ rotation, radii)
    for link, ends, radius in zip(shapes.capsule_links, shapes.capsule_ends,
                                  shapes.capsule_radii):
        a, c = apply_transform(rest[link], ends)
        _capsule(b, link, a, c, radius)
    return b.done(list(skeleton.link_names), floats(inverse(rest[:, :3, :])))


def _local(frame, points):
    """Return world ``points`` in the frame of the 4x4 ``frame``."""
    return (points - frame[:3, 3]) @ frame[:3, :3]


def _ellipsoid(b, link, centre, frame, radii):
    """Add an ellipsoid on ``link``: ``frame`` its axes, ``radii`` along them."""
    rings = []
    for i in range(1, BANDS):
        polar = np.pi * i / BANDS
        rings.append([b.vertex(centre + frame @ (radii * np.array(
            [np.sin(polar) * np.cos(a), np.sin(polar) * np.sin(a), np.cos(polar)])), {link: 1.0})
            for a in np.linspace(0, 2 * np.pi, SIDES, endpoint=False)])
    _close(b, link, rings, centre + frame[:, 2] * radii[2], centre - frame[:, 2] * radii[2])


def _capsule(b, link, a, c, radius):
    """Add a capsule on ``link`` from ``a`` to ``c``: hemispheres joined by a tube."""
    axis = c - a
    length = float(np.linalg.norm(axis))
    axis = axis / length if length > 1e-9 else np.array([0.0, 0.0, 1.0])
    u = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    rings = []
    half = BANDS // 2
    for i in range(1, BANDS):
        polar = np.pi * i / BANDS
        end = c if i < half else a if i > half else None
        centres = [c, a] if end is None else [end]
        for centre in centres:
            rings.append([b.vertex(centre + radius * (np.cos(polar) * axis + np.sin(polar) * (
                np.cos(t) * u + np.sin(t) * v)), {link: 1.0})
                for t in np.linspace(0, 2 * np.pi, SIDES, endpoint=False)])
    _close(b, link, rings, c + radius * axis, a - radius * axis)


def _close(b, link, rings, top, bottom):
    """Join rings (top to bottom) and cap both ends with a pole vertex."""
    for upper, lower in zip(rings, rings[1:]):
        b.quad_strip(upper, lower, BODY, lining=False, closed=True)
    n = len(rings[0])
    pole_top, pole_bottom = b.vertex(top, {link: 1.0}), b.vertex(bottom, {link: 1.0})
    for i in range(n):
        j = (i + 1) % n
        b.triangle((pole_top, rings[0][i], rings[0][j]), BODY, lining=False)
        b.triangle((pole_bottom, rings[-1][j], rings[-1][i]), BODY, lining=False)
