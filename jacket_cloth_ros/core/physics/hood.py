# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The hood (numba): M8, one Verlet particle on a rod from the hood bone's centre."""

import numpy as np

from ..compiled import njit
from .pose import _transform_point


@njit(cache=True)
def hood_step(links, cloth, p, pp, acc, dt, damping, plane_p, plane_n):
    """M8: step one Verlet particle on a rod of fixed length from the hood bone's centre.

    The hood is that of a bundles.ClothModel. The particle stays on the positive side of the
    posed planes (``plane_p``, ``plane_n``, as in a bundles.Posed): a body lying down presses
    its hood onto the floor instead of hanging it through.
    """
    hood_link, pivot, length = cloth.hood_link, cloth.hood_pivot, cloth.hood_length
    anchor = np.empty(3)
    _transform_point(links[hood_link], pivot, anchor)
    d = np.empty(3)
    for k in range(3):
        v = p[k] - pp[k]
        pp[k] = p[k]
        p[k] = p[k] + v * (1.0 - damping) + acc[k] * dt * dt
        d[k] = p[k] - anchor[k]
    n = np.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    if n > 1e-9:
        for k in range(3):
            p[k] = anchor[k] + d[k] * (length / n)
    rest_on_planes(p, anchor, length, plane_p, plane_n)


@njit(cache=True)
def rest_on_planes(p, anchor, length, plane_p, plane_n):
    """Keep the particle ``p`` on its rod from ``anchor`` and on the planes' positive side.

    A particle below a plane goes to the nearest point of the rod's sphere that is on no
    plane's negative side: where the sphere meets one plane (the floor), or where it meets
    two (a floor and a wall). None such (an anchor deep under a plane), or a particle that is
    not finite (the step's check finds it), leaves it as it is.
    """
    if _above_all(p, plane_p, plane_n):
        return
    best, q, kept = np.inf, np.empty(3), p.copy()
    m = plane_p.shape[0]
    for j in range(m):
        if _on_circle(p, anchor, length, plane_p[j], plane_n[j], q) \
                and _above_all(q, plane_p, plane_n):
            best = _keep_nearer(p, q, best, kept)
    for j in range(m):
        for k in range(j + 1, m):
            for side in (-1.0, 1.0):
                if _on_two(anchor, length, plane_p[j], plane_n[j], plane_p[k], plane_n[k],
                           side, q) and _above_all(q, plane_p, plane_n):
                    best = _keep_nearer(p, q, best, kept)
    p[:] = kept


@njit(cache=True)
def _above_all(p, plane_p, plane_n):
    """Tell whether a point is on no plane's negative side (a point not finite is, too)."""
    for j in range(plane_p.shape[0]):
        if _height(p, plane_p[j], plane_n[j]) < -ON_PLANE:
            return False
    return True


# Rounding: a point this far (m) under a plane it was put on is on it.
ON_PLANE = 1e-12


@njit(cache=True, inline='always')
def _height(p, point, normal):
    """Return a point's signed height over a plane (a point on it and its unit normal)."""
    return ((p[0] - point[0]) * normal[0] + (p[1] - point[1]) * normal[1]
            + (p[2] - point[2]) * normal[2])


@njit(cache=True)
def _keep_nearer(p, q, best, kept):
    """Copy ``q`` into ``kept`` if it is nearer ``p`` than ``best``; return the nearest."""
    d = (q[0] - p[0]) ** 2 + (q[1] - p[1]) ** 2 + (q[2] - p[2]) ** 2
    if d < best:
        kept[:] = q
        return d
    return best


@njit(cache=True)
def _on_circle(p, anchor, length, point, normal, out):
    """Put in ``out`` the point nearest ``p`` where the rod's sphere meets a plane; False if none.

    Along the plane it goes the way the rod leans (a rod straight through the plane: any way).
    """
    h = _height(anchor, point, normal)
    if not abs(h) < length:
        return False
    along = np.empty(3)
    for k in range(3):
        along[k] = p[k] - anchor[k]
    up = along[0] * normal[0] + along[1] * normal[1] + along[2] * normal[2]
    for k in range(3):
        along[k] -= up * normal[k]
    a = np.sqrt(along[0] ** 2 + along[1] ** 2 + along[2] ** 2)
    if a <= 1e-9:
        # The normal crossed with the axis it is least along.
        k = 0 if abs(normal[0]) <= min(abs(normal[1]), abs(normal[2])) else (
            1 if abs(normal[1]) <= abs(normal[2]) else 2)
        axis = np.zeros(3)
        axis[k] = 1.0
        along = np.cross(normal, axis)
        a = np.sqrt(along[0] ** 2 + along[1] ** 2 + along[2] ** 2)
    reach = np.sqrt(length * length - h * h)
    for k in range(3):
        out[k] = anchor[k] - h * normal[k] + along[k] * (reach / a)
    return True


@njit(cache=True)
def _on_two(anchor, length, point_a, normal_a, point_b, normal_b, side, out):
    """Put in ``out`` one of the two points where the rod's sphere meets two planes' line.

    ``side`` (-1 or 1) picks which; False if the planes are parallel or the line misses.
    """
    d = np.cross(normal_a, normal_b)
    dd = d[0] ** 2 + d[1] ** 2 + d[2] ** 2
    if dd < 1e-12:
        return False
    # The line's point nearest the anchor: the anchor moved onto both planes along them.
    ha, hb = _height(anchor, point_a, normal_a), _height(anchor, point_b, normal_b)
    c = normal_a[0] * normal_b[0] + normal_a[1] * normal_b[1] + normal_a[2] * normal_b[2]
    det = 1.0 - c * c
    u = (ha - c * hb) / det
    v = (hb - c * ha) / det
    near = np.empty(3)
    for k in range(3):
        near[k] = anchor[k] - u * normal_a[k] - v * normal_b[k]
    gone = (near[0] - anchor[0]) ** 2 + (near[1] - anchor[1]) ** 2 + (near[2] - anchor[2]) ** 2
    if gone > length * length:
        return False
    t = side * np.sqrt((length * length - gone) / dd)
    for k in range(3):
        out[k] = near[k] + t * d[k]
    return True
