# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The cloth grid as a mesh: vertex indices of its triangles and edges.

The cloth's vertices are a ``rows`` x ``cols`` grid stored row by row (index ``r * cols + c``),
row 0 at the top; markers, pictures and the lab's checks draw or judge the same mesh.
"""

import functools

import numpy as np


@functools.lru_cache(maxsize=8)
def grid_triangles(rows: int, cols: int) -> np.ndarray:
    """Vertex indices of the cloth mesh: two triangles per grid quad, flat (3 per triangle).

    :param rows: the grid's vertex rows.
    :param cols: the grid's vertex columns.
    """
    tri = []
    for r in range(rows - 1):
        for c in range(cols - 1):
            a, b, d, e = r * cols + c, r * cols + c + 1, (r + 1) * cols + c, (r + 1) * cols + c + 1
            tri += [a, d, b, b, d, e]
    return np.array(tri)


@functools.lru_cache(maxsize=8)
def grid_lines(rows: int, cols: int) -> np.ndarray:
    """Vertex indices of the grid's horizontal and vertical edges, flat (2 per edge).

    :param rows: the grid's vertex rows.
    :param cols: the grid's vertex columns.
    """
    lines = []
    for r in range(rows):
        for c in range(cols):
            i = r * cols + c
            if c + 1 < cols:
                lines += [i, i + 1]
            if r + 1 < rows:
                lines += [i, i + cols]
    return np.array(lines)
