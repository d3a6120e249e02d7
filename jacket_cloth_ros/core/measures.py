# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What a viewer sees wrong in a cloth state: stretched or folded edges, cloth inside the body.

Measured on the state as published (after the step), each with where it is, so a report can
name the instant, the vertex and the collider. Stretch and compression are kept apart: a hem
folding where a thigh lifts it is not a rubber-band hem.
"""

from typing import TYPE_CHECKING, NamedTuple, Sequence

import numpy as np

from .bundles import Colliders

if TYPE_CHECKING:           # for the annotations only
    from .rig import Rig


SURFACE = 1e-6         # m: depths below this are rounding, the vertex is on the surface


class Worst(NamedTuple):
    """The worst value of one measure in a state, and where it is."""

    value: float
    vertex: int             # the grid vertex (row * cols + col), -1 if none
    collider: str = ''      # for depths inside the body: which collider


def edge_strain(x: np.ndarray, a: np.ndarray, b: np.ndarray, rest: np.ndarray) -> tuple:
    """Return (worst stretch, worst compression) of edges a-b against their rest lengths.

    As ``length / rest - 1`` and ``1 - length / rest`` (0 if none); each names the edge's
    lower vertex ``b``.

    :param x: the vertices' positions, (N, 3) in m.
    :param a: each edge's first vertex.
    :param b: each edge's second (lower) vertex.
    :param rest: each edge's rest length, m.
    """
    if len(a) == 0:
        return Worst(0.0, -1), Worst(0.0, -1)
    ratio = np.linalg.norm(x[a] - x[b], axis=1) / rest
    s, c = int(np.argmax(ratio)), int(np.argmin(ratio))
    return (Worst(max(0.0, float(ratio[s] - 1.0)), int(b[s])),
            Worst(max(0.0, float(1.0 - ratio[c])), int(b[c])))


def depth_inside(x: np.ndarray, free: np.ndarray, colliders: 'Colliders',
                 labels: Sequence[str]) -> Worst:
    """Find the deepest free vertex inside any collider (m), with the collider's label.

    Depth is the distance to the surface point the push-out would move the vertex to.

    :param x: the vertices' positions, (N, 3) in m.
    :param free: which vertices are free (not pinned), (N,).
    :param colliders: the body's colliders in the frame of ``x``.
    :param labels: one name per ellipsoid, capsule and plane, in that order.
    """
    best = Worst(SURFACE, -1)       # on the surface (rounding) is not inside
    idx = np.flatnonzero(free)
    if len(idx) == 0:
        return Worst(0.0, -1)
    p = x[idx]
    k = 0
    for c, axes, radii in zip(colliders.centers, colliders.axes, colliders.radii):
        q = ((p - c) @ axes) / radii
        r = np.linalg.norm(q, axis=1)
        hit = (r < 1.0) & (r > 1e-12)
        if hit.any():
            surface = (q[hit] / r[hit, None] * radii) @ axes.T + c
            d = np.linalg.norm(surface - p[hit], axis=1)
            j = int(np.argmax(d))
            if d[j] > best.value:
                best = Worst(float(d[j]), int(idx[hit][j]), labels[k])
        k += 1
    for a, b, radius in zip(colliders.capsule_a, colliders.capsule_b, colliders.capsule_radii):
        ab = b - a
        t = np.clip(((p - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        d = radius - np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
        j = int(np.argmax(d))
        if d[j] > best.value:
            best = Worst(float(d[j]), int(idx[j]), labels[k])
        k += 1
    for point, normal in zip(colliders.plane_points, colliders.plane_normals):
        d = -((p - point) @ normal)
        j = int(np.argmax(d))
        if d[j] > best.value:
            best = Worst(float(d[j]), int(idx[j]), labels[k])
        k += 1
    return best if best.vertex >= 0 else Worst(0.0, -1)


def collider_labels(rig: 'Rig') -> list:
    """Return the rig's name of each collider, in the order of bundles.Colliders.

    :param rig: the rig whose ellipsoids, capsules and planes are named.
    """
    return [c.name for c in (*rig.colliders, *rig.capsules, *rig.planes)]
