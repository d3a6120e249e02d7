# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A simple body for the jacket to sit on, where the character's URDF has no visuals of its own.

Made of what the cloth already knows of the body: the rig's M10 ellipsoids and capsules, then a
capsule along every skeleton segment they leave bare (arms, neck, feet) and a head on the hood's
link's child. Each piece rides rigidly on one link: a mesh of the same kind as the jacket's
(jacket_mesh.SkinnedMesh), so it is posed, shaded and exported by the same code.
"""

from typing import TYPE_CHECKING

import numpy as np

from .bundles import floats
from .jacket_mesh import BODY, MeshBuilder, inverse
from .transforms import apply_transform

if TYPE_CHECKING:           # for the annotations only
    from .jacket_mesh import SkinnedMesh
    from .rig import Rig
    from .skeleton import Skeleton

SIDES, BANDS = 8, 4         # round an ellipsoid or capsule, and from pole to pole


def body_mesh(skeleton: 'Skeleton', rig: 'Rig') -> 'SkinnedMesh':
    """Build the body: the rig's colliders, capsules on the bare segments, a head.

    Its joints are the skeleton's links.

    :param skeleton: the character.
    :param rig: its rig (colliders, the hood's link for the head, the body's up).
    """
    rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    b = MeshBuilder()
    covered = set()
    for link, centre, rotation, radii in zip(rig.collider_links, rig.collider_centers,
                                             rig.collider_rotations, rig.collider_radii):
        frame = rest[link][:3, :3] @ rotation
        _ellipsoid(b, link, apply_transform(rest[link], centre[None])[0], frame, radii)
        covered.add(int(link))
    for link, (a, c), radius in zip(rig.capsule_links, rig.capsule_ends, rig.capsule_radii):
        ends = apply_transform(rest[link], np.array([a, c]))
        _capsule(b, link, ends[0], ends[1], radius)
        covered.add(int(link))
    size = max(rig.height_m, 0.3)
    limb = float(np.clip(0.024 * size, 0.01, 0.06))
    head_link = rig.hood.link
    for child in range(1, len(skeleton.link_names)):
        parent = int(skeleton.parent[child])
        a, c = rest[parent][:3, 3], rest[child][:3, 3]
        if parent in covered or np.linalg.norm(c - a) < 0.04 * size:
            continue
        _capsule(b, parent, a, c, limb)
    heads = [k for k in range(len(skeleton.link_names)) if skeleton.parent[k] == head_link]
    top = heads[0] if heads else head_link
    r = 0.065 * size
    up = rig.world_axes[:, 2]
    centre = rest[top][:3, 3] + up * 0.7 * r
    # A head link whose origin sits in the torso (a robot's, fixed at the waist) would bury
    # the head: it stays above the hood's pivot, which the rig puts behind the neck.
    pivot = apply_transform(rest[head_link], rig.hood.pivot[None])[0]
    centre = centre + up * max(0.0, r - float((centre - pivot) @ up))
    _ellipsoid(b, top, centre, rig.world_axes, np.array([0.9 * r, 0.8 * r, r]))
    return b.done(list(skeleton.link_names), floats(inverse(rest[:, :3, :])))


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
