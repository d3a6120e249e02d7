# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""/tf, marker and diagnostic messages from the simulation's state, as CDR bytes (cdr.py)."""

import functools
from dataclasses import dataclass

import numpy as np

from ..core.transforms import cross, matrix_to_quat
from . import cdr

# visualization_msgs/Marker constants
SPHERE, CUBE, CYLINDER, LINE_LIST, TRIANGLE_LIST = 2, 1, 3, 5, 11
ADD, DELETEALL = 0, 3
# diagnostic_msgs/DiagnosticStatus levels
OK, WARN = 0, 1

MARKER_NAMESPACES = ('cloth', 'colliders', 'hood', 'jacket_bones')
TWEED = (0.42, 0.33, 0.24, 0.9)
SEAM = (0.2, 0.15, 0.1, 1.0)
GHOST = (0.4, 0.6, 0.9, 0.25)
HOOD = (0.55, 0.42, 0.3, 1.0)
IDENTITY = (0.0, 0.0, 0.0, 1.0)


@dataclass
class MarkerSpec:
    ns: str
    id: int
    type: int
    action: int = ADD
    position: tuple = (0.0, 0.0, 0.0)
    orientation: tuple = IDENTITY
    scale: tuple = (1.0, 1.0, 1.0)
    color: tuple = (0.0, 0.0, 0.0, 0.0)
    points: np.ndarray = None
    lifetime_s: int = 1          # stale markers vanish if the node stops


def stamp_msg(stamp_ns):
    from builtin_interfaces.msg import Time
    return Time(sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000))


def tf_message(bones, stamp_ns, prefix=''):
    """One TFMessage with every bone, each a child of an existing skeleton link."""
    return _tf_template(tuple(bones.names), tuple(bones.parents), prefix).encode(
        bones.translations, bones.quaternions, stamp_ns)


@functools.lru_cache(maxsize=8)
def _tf_template(names, parents, prefix):
    return cdr.TfTemplate(names, parents, prefix)


@functools.lru_cache(maxsize=8)
def grid_triangles(rows, cols):
    """Vertex indices of the cloth mesh: two triangles per grid quad."""
    tri = []
    for r in range(rows - 1):
        for c in range(cols - 1):
            a, b, d, e = r * cols + c, r * cols + c + 1, (r + 1) * cols + c, (r + 1) * cols + c + 1
            tri += [a, d, b, b, d, e]
    return np.array(tri)


@functools.lru_cache(maxsize=8)
def grid_lines(rows, cols):
    lines = []
    for r in range(rows):
        for c in range(cols):
            i = r * cols + c
            if c + 1 < cols:
                lines += [i, i + 1]
            if r + 1 < rows:
                lines += [i, i + cols]
    return np.array(lines)


def _z_to(direction):
    """Quaternion (x, y, z, w) turning +z onto the unit ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = cross(z, direction)
    s, c = np.linalg.norm(axis), float(z @ direction)
    if s < 1e-9:
        return (1.0, 0.0, 0.0, 0.0) if c < 0 else IDENTITY
    half = np.arctan2(s, c) / 2
    v = axis / s * np.sin(half)
    return (float(v[0]), float(v[1]), float(v[2]), float(np.cos(half)))


def marker_specs(sim, reset=False):
    """Cloth mesh and seams, colliders, hood pendulum, jacket bones; DELETEALL after a reset."""
    out = [MarkerSpec(ns, 0, 0, action=DELETEALL, lifetime_s=0)
           for ns in MARKER_NAMESPACES] if reset else []
    rig = sim.rig
    out.append(MarkerSpec('cloth', 0, TRIANGLE_LIST, color=TWEED,
                          points=sim.x[grid_triangles(rig.rows, rig.cols)]))
    out.append(MarkerSpec('cloth', 1, LINE_LIST, scale=(0.004, 1.0, 1.0), color=SEAM,
                          points=sim.x[grid_lines(rig.rows, rig.cols)]))
    c = sim.collider_frames(sim.links)
    quats = matrix_to_quat(c.axes)
    for k in range(len(c.centers)):
        out.append(MarkerSpec('colliders', k, SPHERE, position=tuple(c.centers[k]),
                              orientation=tuple(quats[k]), scale=tuple(2 * c.radii[k]),
                              color=GHOST))
    mid = len(c.centers)
    for a, b, r in zip(c.capsule_a, c.capsule_b, c.capsule_radii):
        # A capsule drawn as its cylinder and two end spheres.
        axis = b - a
        length = float(np.linalg.norm(axis))
        out.append(MarkerSpec('colliders', mid, CYLINDER, position=tuple((a + b) / 2),
                              orientation=_z_to(axis / max(length, 1e-9)),
                              scale=(2 * r, 2 * r, length), color=GHOST))
        for k, end in enumerate((a, b)):
            out.append(MarkerSpec('colliders', mid + 1 + k, SPHERE, position=tuple(end),
                                  scale=(2 * r,) * 3, color=GHOST))
        mid += 3
    for p, n in zip(c.plane_points, c.plane_normals):
        # A plane drawn as a thin 2 m square below the character's root.
        out.append(MarkerSpec('colliders', mid, CUBE, position=tuple((p @ n) * n),
                              orientation=_z_to(n), scale=(2.0, 2.0, 0.002), color=GHOST))
        mid += 1
    anchor, _ = sim.hood_anchor(sim.links)
    out.append(MarkerSpec('hood', 0, LINE_LIST, scale=(0.01, 1.0, 1.0), color=HOOD,
                          points=np.array([anchor, sim.hood_p])))
    out.append(MarkerSpec('hood', 1, SPHERE, position=tuple(sim.hood_p), scale=(0.05,) * 3,
                          color=HOOD))
    if sim.layer is not None:
        # M1/M2 layer bones as segments from their pivots to their tips.
        segments = np.stack([sim.layer.positions, sim.layer.tips], axis=1).reshape(-1, 3)
        out.append(MarkerSpec('jacket_bones', 0, LINE_LIST, scale=(0.012, 1.0, 1.0),
                              color=SEAM, points=segments))
    return out


def marker_array(sim, stamp_ns, frame, reset=False):
    specs = marker_specs(sim, reset)
    return _marker_template(cdr.marker_layout(specs, frame)).encode(specs, stamp_ns)


@functools.lru_cache(maxsize=8)
def _marker_template(layout):
    """One per layout: the reset array, with its DELETEALLs in front, is another."""
    return cdr.MarkerTemplate(layout)


def diagnostics(stamp_ns, node_name, values, level_warn, message):
    status = (WARN if level_warn else OK, f'{node_name}: cloth simulation', message,
              'jacket_cloth', values)
    return cdr.diagnostic_array(stamp_ns, [status])
