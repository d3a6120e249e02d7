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
    """Keep the particle ``p`` on its rod from ``anchor`` and on the planes' positive side."""
    for j in range(plane_p.shape[0]):
        _rest_on_plane(p, anchor, length, plane_p[j], plane_n[j])


@njit(cache=True)
def _rest_on_plane(p, anchor, length, point, normal):
    """Move a particle below a plane onto it, keeping the rod's length and its side.

    The particle goes where the rod meets the plane, in the direction the rod already leans
    along it; an anchor a rod's length or more below the plane leaves the particle as it is.
    """
    below = ((p[0] - point[0]) * normal[0] + (p[1] - point[1]) * normal[1]
             + (p[2] - point[2]) * normal[2])
    if not below < 0.0:         # above, or not finite: a NaN stays for the step to find
        return
    h = ((anchor[0] - point[0]) * normal[0] + (anchor[1] - point[1]) * normal[1]
         + (anchor[2] - point[2]) * normal[2])
    if h <= -length:
        return
    along = np.empty(3)
    for k in range(3):
        along[k] = p[k] - anchor[k]
    up = along[0] * normal[0] + along[1] * normal[1] + along[2] * normal[2]
    for k in range(3):
        along[k] -= up * normal[k]
    a = np.sqrt(along[0] ** 2 + along[1] ** 2 + along[2] ** 2)
    reach = np.sqrt(max(length * length - h * h, 0.0))
    for k in range(3):
        p[k] = anchor[k] - h * normal[k]
        if a > 1e-9:
            p[k] += along[k] * (reach / a)
