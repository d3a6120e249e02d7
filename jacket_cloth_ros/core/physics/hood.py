# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The hood (numba): M8, one Verlet particle on a rod from the hood bone's centre."""

import numpy as np

from ..compiled import njit
from .pose import _transform_point


@njit(cache=True)
def hood_step(links, cloth, p, pp, acc, dt, damping):
    """M8: step one Verlet particle on a rod of fixed length from the hood bone's centre.

    The hood is that of a bundles.ClothModel.
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
