# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The poses of the solid markers (colliders, hood, the body's pieces), compiled.

Why compiled: worked out in numpy, one marker per collider, they cost more than a cloth step
per MarkerArray (docs/performance.md). One row per solid marker:
position (3), orientation (x, y, z, w) and scale (3), in the order messages.marker_layout lists
them: the debug layer's shapes (shape_count), then the body's (body_count).
"""

from typing import TYPE_CHECKING

import numpy as np

from ..core.bundles import ColliderModel, Posed
from ..core.compiled import njit
from ..core.physics.colliders import collider_poses, plane_poses
from ..core.physics.pose import _transform_point, quat_from_matrix

if TYPE_CHECKING:           # for the annotations only
    from ..core.rig import Rig

POSE_WIDTH = 10
HOOD_SPHERE = 0.05                 # diameter of the hood particle's sphere, m
PLANE_SIZE, PLANE_THICKNESS = 2.0, 0.002


def shape_count(rig: 'Rig') -> int:
    """Rows of shape_poses for ``rig``: ellipsoids, three per capsule, planes, the hood.

    :param rig: the character's rig.
    """
    return len(rig.collider_links) + 3 * len(rig.capsule_links) + len(rig.plane_links) + 1


def body_count(body: ColliderModel) -> int:
    """Rows of the body's pieces (core.body_mesh.body_shapes): ellipsoids, three per capsule.

    :param body: the body's pieces.
    """
    return len(body.links) + 3 * len(body.capsule_links)


@njit(cache=True, nogil=True)
def shape_poses(centers, axes, radii, cap_a, cap_b, cap_r, plane_p, plane_n, hood_p, out):
    """Pose the marker shapes into ``out``.

    Ellipsoids and capsules as :func:`solid_poses`; a plane as a thin square at its point
    nearest the origin (the root); the hood particle as a sphere.
    """
    j = solid_poses(centers, axes, radii, cap_a, cap_b, cap_r, out)
    for k in range(plane_p.shape[0]):
        n = plane_n[k]
        along = _dot(plane_p[k], n)
        for i in range(3):
            out[j, i] = along * n[i]
        _z_to(n[0], n[1], n[2], out[j, 3:7])
        out[j, 7], out[j, 8], out[j, 9] = PLANE_SIZE, PLANE_SIZE, PLANE_THICKNESS
        j += 1
    out[j, :3] = hood_p
    _identity(out[j, 3:7])
    out[j, 7:] = HOOD_SPHERE


@njit(cache=True, nogil=True)
def solid_poses(centers, axes, radii, cap_a, cap_b, cap_r, out):
    """Pose ellipsoids as scaled spheres, a capsule as its cylinder and two end spheres.

    Returns the rows written.
    """
    # Element by element: array arithmetic here made a temporary for each term, and each was
    # an allocation and an atomic reference count.
    j = 0
    for k in range(centers.shape[0]):
        for i in range(3):
            out[j, i] = centers[k, i]
            out[j, 7 + i] = 2.0 * radii[k, i]
        quat_from_matrix(axes[k], out[j, 3:7])
        j += 1
    for k in range(cap_a.shape[0]):
        d = 2.0 * cap_r[k]
        x0, x1, x2 = cap_b[k, 0] - cap_a[k, 0], cap_b[k, 1] - cap_a[k, 1], \
            cap_b[k, 2] - cap_a[k, 2]
        length = np.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        for i in range(3):
            out[j, i] = 0.5 * (cap_a[k, i] + cap_b[k, i])
        over = max(length, 1e-9)
        _z_to(x0 / over, x1 / over, x2 / over, out[j, 3:7])
        out[j, 7], out[j, 8], out[j, 9] = d, d, length
        for e in range(2):
            end = cap_a if e == 0 else cap_b
            for i in range(3):
                out[j + 1 + e, i] = end[k, i]
                out[j + 1 + e, 7 + i] = d
            _identity(out[j + 1 + e, 3:7])
        j += 3
    return j


@njit(cache=True, nogil=True)
def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]       # numpy's @ would need scipy's BLAS


@njit(cache=True, nogil=True)
def _identity(q):
    q[0], q[1], q[2], q[3] = 0.0, 0.0, 0.0, 1.0


@njit(cache=True, nogil=True)
def _z_to(d0, d1, d2, q):
    """Quaternion (x, y, z, w) turning +z onto the unit direction ``(d0, d1, d2)``."""
    # axis = z x d = (-d1, d0, 0); turn by atan2(|axis|, d2) about it.
    s = np.sqrt(d0 * d0 + d1 * d1)
    if s < 1e-9:
        if d2 < 0:
            q[0], q[1], q[2], q[3] = 1.0, 0.0, 0.0, 0.0
        else:
            _identity(q)
        return
    half = 0.5 * np.arctan2(s, d2)
    f = np.sin(half) / s
    q[0], q[1], q[2], q[3] = -d1 * f, d0 * f, 0.0, np.cos(half)


@njit(cache=True, nogil=True)
def marker_table(model, scene, body):
    """Return (table, pose rows): the pose table and the point table, flattened in turn.

    The pose table has shape_poses' rows: the colliders of a bundles.Model on the scene's
    links, and the hood particle; then solid_poses' rows of the body's pieces (a
    bundles.ColliderModel) on those links. The point table holds the cloth's vertices, the
    hood's anchor and particle, the layer bones' pivots and their tips.
    """
    colliders, x, hood_p = model.colliders, scene.x, scene.hood_p
    k_caps = colliders.capsule_links.shape[0]
    nv = x.shape[0]
    posed = Posed(np.empty(colliders.centers.shape), np.empty(colliders.rotations.shape),
                  np.empty((k_caps, 3)), np.empty((k_caps, 3)),
                  np.empty(colliders.plane_points.shape), np.empty(colliders.plane_normals.shape),
                  np.empty((0, 3)))
    collider_poses(scene.links, colliders, posed)
    plane_poses(scene.links, scene.root, colliders, posed)
    debug_rows = posed.centers.shape[0] + 3 * k_caps + posed.plane_p.shape[0] + 1
    b_caps = body.capsule_links.shape[0]
    rows = debug_rows + body.links.shape[0] + 3 * b_caps
    k = scene.layer_pos.shape[0]
    table = np.empty(rows * POSE_WIDTH + 3 * (nv + 2 + 2 * k))
    poses = table[:rows * POSE_WIDTH].reshape((rows, POSE_WIDTH))        # posed in place
    shape_poses(posed.centers, posed.axes, colliders.radii, posed.cap_a, posed.cap_b,
                colliders.capsule_radii, posed.plane_p, posed.plane_n, hood_p, poses)
    body_poses(scene.links, body, poses[debug_rows:])
    points = table[rows * POSE_WIDTH:].reshape((nv + 2 + 2 * k, 3))
    points[:nv] = x
    cloth = model.cloth
    _transform_point(scene.links[cloth.hood_link], cloth.hood_pivot, points[nv])  # hood anchor
    points[nv + 1] = hood_p
    points[nv + 2:nv + 2 + k] = scene.layer_pos
    points[nv + 2 + k:] = scene.layer_tips
    return table, rows


@njit(cache=True, nogil=True)
def fill_markers(model, scene, body, src, dst, out):
    """Run marker_table, then cdr.MarkerTemplate's scatter ``out[dst] = table[src]``, in one call.

    As separate numpy and compiled calls they cost several times as much in a node that
    sleeps between inputs (caches cold).
    """
    table, _ = marker_table(model, scene, body)
    for i in range(dst.shape[0]):
        out[dst[i]] = table[src[i]]


@njit(cache=True, nogil=True)
def body_poses(links, body, out):
    """Pose the body's pieces (a bundles.ColliderModel) on ``links`` into ``out``'s rows."""
    caps = body.capsule_links.shape[0]
    pieces = Posed(np.empty(body.centers.shape), np.empty(body.rotations.shape),
                   np.empty((caps, 3)), np.empty((caps, 3)), np.empty((0, 3)),
                   np.empty((0, 3)), np.empty((0, 3)))
    collider_poses(links, body, pieces)
    solid_poses(pieces.centers, pieces.axes, body.radii, pieces.cap_a, pieces.cap_b,
                body.capsule_radii, out)


@njit(cache=True, nogil=True)
def fill_body(links, body, first, src, dst, out):
    """Pose only the body's pieces and scatter them as fill_markers would (no debug layer).

    The layout then reads nothing else of the tables; the rest of marker_table would be a
    large share of a markers message.

    :param links: (L,4,4) the links now.
    :param body: the body's pieces (a bundles.ColliderModel).
    :param first: the pose table's row of the body's first piece.
    """
    table = np.empty((body.links.shape[0] + 3 * body.capsule_links.shape[0], POSE_WIDTH))
    body_poses(links, body, table)
    flat = table.reshape(-1)
    skip = first * POSE_WIDTH
    for i in range(dst.shape[0]):
        out[dst[i]] = flat[src[i] - skip]
