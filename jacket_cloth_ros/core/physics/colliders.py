# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The body the cloth cannot enter (numba): M10 ellipsoids, capsules and planes.

Posed on their links each step (``collider_poses``, ``plane_poses``), then read by the
push-outs through one bundles.Body (``body_of``): ellipsoids are tested in the space where
each is a unit sphere. Capsules and planes are the primitives the best secondary-motion
systems add (limbs, the floor).
"""

import numpy as np

from ..bundles import Body, Colliders
from ..compiled import njit
from .pose import _matmul3, _transform_point, relative_move


@njit(cache=True)
def collider_poses(links, colliders, posed):
    """Pose the M10 ellipsoids and capsule ends of a bundles.ColliderModel into a bundles.Posed.

    Each on its link; an ellipsoid as its centre and its axes as columns.
    """
    links_of, centers_local, rotations_local = (colliders.links, colliders.centers,
                                                colliders.rotations)
    capsule_links, capsule_ends = colliders.capsule_links, colliders.capsule_ends
    centers, axes, cap_a, cap_b = posed.centers, posed.axes, posed.cap_a, posed.cap_b
    for e in range(centers.shape[0]):
        t = links[links_of[e]]
        _transform_point(t, centers_local[e], centers[e])
        _matmul3(t[:3, :3], rotations_local[e], axes[e])
    for k in range(cap_a.shape[0]):
        t = links[capsule_links[k]]
        _transform_point(t, capsule_ends[k, 0], cap_a[k])
        _transform_point(t, capsule_ends[k, 1], cap_b[k])


@njit(cache=True)
def plane_poses(links, root, colliders, posed):
    """Pose the planes of a bundles.ColliderModel on their links into a bundles.Posed.

    A plane fixed in the world (link < 0) is seen from ``root``.
    """
    plane_links, points_local = colliders.plane_links, colliders.plane_points
    normals_local, points, normals = colliders.plane_normals, posed.plane_p, posed.plane_n
    frame = np.empty((4, 4))
    for k in range(points.shape[0]):
        plane_pose(links, root, plane_links[k], points_local[k], normals_local[k], frame,
                   points[k], normals[k])


@njit(cache=True)
def plane_pose(links, root, link, point_local, normal_local, frame, point, normal):
    """Pose one plane on its link (``link`` < 0: fixed in the world, seen from ``root``).

    Into ``point`` and ``normal``; ``frame`` (4,4) is scratch.
    """
    if link < 0:
        relative_move(root, np.eye(4), frame)          # world -> the root's local frame
    else:
        frame[:] = links[link]
    _transform_point(frame, point_local, point)
    for r in range(3):
        normal[r] = (frame[r, 0] * normal_local[0] + frame[r, 1] * normal_local[1]
                     + frame[r, 2] * normal_local[2])


@njit(cache=True)
def body_of(colliders):
    """Return the bundles.Body of a bundles.Colliders: each ellipsoid's maps, computed once.

    The map into the space where an ellipsoid is a unit sphere (its axes as rows over its
    radii), the map back, and the squared radius of its bounding sphere.
    """
    axes, radii = colliders.axes, colliders.radii
    ne = radii.shape[0]
    to_unit, from_unit, reach2 = np.empty((ne, 3, 3)), np.empty((ne, 3, 3)), np.empty(ne)
    for e in range(ne):
        for k in range(3):
            for r in range(3):
                to_unit[e, k, r] = axes[e, r, k] / radii[e, k]
                from_unit[e, r, k] = axes[e, r, k] * radii[e, k]
        reach = max(radii[e, 0], max(radii[e, 1], radii[e, 2]))
        reach2[e] = reach * reach
    return Body(colliders.centers, to_unit, from_unit, reach2, colliders.capsule_a,
                colliders.capsule_b, colliders.capsule_radii, colliders.plane_points,
                colliders.plane_normals)


@njit(cache=True)
def posed_body(colliders, posed):
    """Return the bundles.Body of a ColliderModel's colliders where a bundles.Posed puts them."""
    return body_of(Colliders(posed.centers, posed.axes, colliders.radii, posed.cap_a,
                             posed.cap_b, colliders.capsule_radii, posed.plane_p, posed.plane_n))


@njit(cache=True)
def _push_capsule(x, i, cap_a, cap_b, cap_r, k):
    """Push vertex i out of capsule k (segment a-b swept by a sphere). Returns depth."""
    ab0, ab1, ab2 = cap_b[k, 0] - cap_a[k, 0], cap_b[k, 1] - cap_a[k, 1], cap_b[k, 2] - cap_a[k, 2]
    ap0, ap1, ap2 = x[i, 0] - cap_a[k, 0], x[i, 1] - cap_a[k, 1], x[i, 2] - cap_a[k, 2]
    len2 = ab0 * ab0 + ab1 * ab1 + ab2 * ab2
    t = 0.0
    if len2 > 1e-12:
        t = (ap0 * ab0 + ap1 * ab1 + ap2 * ab2) / len2
        t = min(1.0, max(0.0, t))
    d0, d1, d2 = ap0 - t * ab0, ap1 - t * ab1, ap2 - t * ab2
    dist = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    radius = cap_r[k]
    if dist >= radius or dist < 1e-12:
        return -1.0
    g = radius / dist
    x[i, 0] = cap_a[k, 0] + t * ab0 + d0 * g
    x[i, 1] = cap_a[k, 1] + t * ab1 + d1 * g
    x[i, 2] = cap_a[k, 2] + t * ab2 + d2 * g
    return radius - dist


@njit(cache=True)
def _push_plane(x, i, plane_p, plane_n, k):
    """Keep vertex i on the positive side of plane k (unit normal). Returns depth."""
    h = ((x[i, 0] - plane_p[k, 0]) * plane_n[k, 0] + (x[i, 1] - plane_p[k, 1]) * plane_n[k, 1]
         + (x[i, 2] - plane_p[k, 2]) * plane_n[k, 2])
    if h >= 0.0:
        return -1.0
    x[i, 0] -= h * plane_n[k, 0]
    x[i, 1] -= h * plane_n[k, 1]
    x[i, 2] -= h * plane_n[k, 2]
    return -h


MAX_COLLISION_PASSES = 4


# The Body as three plain tuples, not the Body: handed to a function called per vertex, the
# Body's nine arrays were each counted in and out (atomically) per vertex and pass, several
# times the push-out's arithmetic; the loops over the vertices make the tuples once.
@njit(cache=True)
def body_parts(body):
    """Return a bundles.Body as (ellipsoids, capsules, planes), the tuples push_out_of takes.

    ``(centers, to_unit, from_unit, reach2)``, ``(cap_a, cap_b, cap_r)``, ``(plane_p,
    plane_n)``.
    """
    return ((body.centers, body.to_unit, body.from_unit, body.reach2),
            (body.cap_a, body.cap_b, body.cap_r), (body.plane_p, body.plane_n))


@njit(cache=True)
def push_out_of(x, i, ellipsoids, capsules, planes):
    """Push vertex i onto the surface of every collider of a bundles.Body it is inside.

    In one pass; the Body as body_parts gives it. Returns the deepest push-out, or -1 if it
    was inside none.
    """
    centers, to_unit, from_unit, reach2 = ellipsoids
    cap_a, cap_b, cap_r = capsules
    plane_p, plane_n = planes
    deepest = -1.0
    for e in range(centers.shape[0]):
        p0 = x[i, 0] - centers[e, 0]
        p1 = x[i, 1] - centers[e, 1]
        p2 = x[i, 2] - centers[e, 2]
        if p0 * p0 + p1 * p1 + p2 * p2 >= reach2[e]:     # outside the bounding sphere
            continue
        q0 = to_unit[e, 0, 0] * p0 + to_unit[e, 0, 1] * p1 + to_unit[e, 0, 2] * p2
        q1 = to_unit[e, 1, 0] * p0 + to_unit[e, 1, 1] * p1 + to_unit[e, 1, 2] * p2
        q2 = to_unit[e, 2, 0] * p0 + to_unit[e, 2, 1] * p1 + to_unit[e, 2, 2] * p2
        r2 = q0 * q0 + q1 * q1 + q2 * q2
        if r2 >= 1.0 or r2 < 1e-12:
            continue
        g = 1.0 / np.sqrt(r2)          # onto the unit sphere, then back
        s0, s1, s2 = q0 * g, q1 * g, q2 * g
        n0 = (from_unit[e, 0, 0] * s0 + from_unit[e, 0, 1] * s1
              + from_unit[e, 0, 2] * s2 + centers[e, 0])
        n1 = (from_unit[e, 1, 0] * s0 + from_unit[e, 1, 1] * s1
              + from_unit[e, 1, 2] * s2 + centers[e, 1])
        n2 = (from_unit[e, 2, 0] * s0 + from_unit[e, 2, 1] * s1
              + from_unit[e, 2, 2] * s2 + centers[e, 2])
        m0, m1, m2 = n0 - x[i, 0], n1 - x[i, 1], n2 - x[i, 2]
        x[i, 0] = n0
        x[i, 1] = n1
        x[i, 2] = n2
        deepest = max(deepest, np.sqrt(m0 * m0 + m1 * m1 + m2 * m2))
    for k in range(cap_a.shape[0]):
        deepest = max(deepest, _push_capsule(x, i, cap_a, cap_b, cap_r, k))
    for k in range(plane_p.shape[0]):
        deepest = max(deepest, _push_plane(x, i, plane_p, plane_n, k))
    return deepest


@njit(cache=True)
def push_out(x, i, body):
    """push_out_of a bundles.Body, for a single vertex (a loop makes body_parts once)."""
    ellipsoids, capsules, planes = body_parts(body)
    return push_out_of(x, i, ellipsoids, capsules, planes)


# Pushed out of one collider, a vertex can land in an overlapping one (a split ellipsoid, the
# crease of pelvis and thigh): passes until one moves it less than ``settled`` (bounded:
# corners may not settle).
@njit(cache=True)
def push_out_passes_of(x, i, settled, ellipsoids, capsules, planes):
    """Push vertex i out in up to MAX_COLLISION_PASSES passes of push_out_of.

    Returns (deepest push-out or -1 if it was inside none, the last pass's push-out).
    """
    deepest, depth = -1.0, -1.0
    for _ in range(MAX_COLLISION_PASSES):
        depth = push_out_of(x, i, ellipsoids, capsules, planes)
        if depth < settled:
            break
        deepest = max(deepest, depth)
    return deepest, depth


@njit(cache=True)
def collide(x, free, body, contact):
    """M10 and beyond: push particles out of the ellipsoids, capsules and planes of a Body.

    Marks contact for M15. Returns the deepest penetration found (metres, in the simulation
    frame).
    """
    ellipsoids, capsules, planes = body_parts(body)
    deepest = 0.0
    for i in range(x.shape[0]):
        if not free[i]:
            continue
        # push_out_passes_of's passes, written out: called here per vertex, as a function of
        # its own between, it made this loop several times slower.
        passes_deepest = -1.0
        for _ in range(MAX_COLLISION_PASSES):
            depth = push_out_of(x, i, ellipsoids, capsules, planes)
            if depth < 0.0:
                break
            passes_deepest = max(passes_deepest, depth)
        deepest = max(deepest, passes_deepest)
        contact[i] = passes_deepest >= 0.0
    return deepest


@njit(cache=True)
def push_out_points(points, body):
    """M6 with M10: put each skinned (pinned) point on the surface of any collider it is in.

    A pinned vertex cannot move in the solve, so one left inside the body (a thigh raised
    against the jacket's front, a collider fitted a little wide) makes its column either
    stretched or inside; the body lifts the pinned row instead. Returns the deepest move.
    """
    return collide(points, np.ones(points.shape[0], dtype=np.bool_), body,
                   np.empty(points.shape[0], dtype=np.bool_))
