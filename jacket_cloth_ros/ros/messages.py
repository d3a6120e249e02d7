# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Building /tf, marker and diagnostic messages from the simulation's state."""

import functools

import numpy as np
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, TransformStamped
from std_msgs.msg import ColorRGBA
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from ..core.transforms import matrix_to_quat

MARKER_NAMESPACES = ('cloth', 'colliders', 'hood', 'jacket_bones')
TWEED = ColorRGBA(r=0.42, g=0.33, b=0.24, a=0.9)
SEAM = ColorRGBA(r=0.2, g=0.15, b=0.1, a=1.0)
GHOST = ColorRGBA(r=0.4, g=0.6, b=0.9, a=0.25)
HOOD = ColorRGBA(r=0.55, g=0.42, b=0.3, a=1.0)


def stamp_msg(stamp_ns):
    return Time(sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000))


def tf_message(bones, stamp_ns, prefix=''):
    """One TFMessage with every bone, each a child of an existing skeleton link."""
    stamp = stamp_msg(stamp_ns)
    out = TFMessage()
    for name, parent, p, q in zip(bones.names, bones.parents, bones.translations.tolist(),
                                  bones.quaternions.tolist()):
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = parent
        t.child_frame_id = prefix + name
        tr, ro = t.transform.translation, t.transform.rotation
        tr.x, tr.y, tr.z = p
        ro.x, ro.y, ro.z, ro.w = q
        out.transforms.append(t)
    return out


def _points(array):
    return [Point(x=a, y=b, z=c) for a, b, c in array.tolist()]


def _marker(ns, mid, kind, frame, stamp):
    m = Marker()
    m.header.frame_id = frame
    m.header.stamp = stamp
    m.ns, m.id, m.type, m.action = ns, mid, kind, Marker.ADD
    m.pose.orientation.w = 1.0
    m.scale.x = m.scale.y = m.scale.z = 1.0
    m.lifetime = Duration(sec=1)      # stale markers vanish if the node stops
    return m


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


def _place(m, position, quat):
    m.pose.position.x, m.pose.position.y, m.pose.position.z = np.asarray(position).tolist()
    o = m.pose.orientation
    o.x, o.y, o.z, o.w = np.asarray(quat, dtype=float).tolist()


def _z_to(direction):
    """Quaternion (x, y, z, w) turning +z onto the unit ``direction``."""
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, direction)
    s, c = np.linalg.norm(axis), float(z @ direction)
    if s < 1e-9:
        return (1.0, 0.0, 0.0, 0.0) if c < 0 else (0.0, 0.0, 0.0, 1.0)
    half = np.arctan2(s, c) / 2
    v = axis / s * np.sin(half)
    return (v[0], v[1], v[2], np.cos(half))


def marker_array(sim, stamp_ns, frame, reset=False):
    """Cloth mesh and seams, colliders, hood pendulum; DELETEALL per namespace after a reset."""
    stamp = stamp_msg(stamp_ns)
    out = MarkerArray()
    if reset:
        for ns in MARKER_NAMESPACES:
            m = Marker()
            m.header.frame_id, m.header.stamp, m.ns, m.action = frame, stamp, ns, Marker.DELETEALL
            out.markers.append(m)
    rig = sim.rig
    mesh = _marker('cloth', 0, Marker.TRIANGLE_LIST, frame, stamp)
    mesh.color = TWEED
    mesh.points = _points(sim.x[grid_triangles(rig.rows, rig.cols)])
    seams = _marker('cloth', 1, Marker.LINE_LIST, frame, stamp)
    seams.scale.x = 0.004
    seams.color = SEAM
    seams.points = _points(sim.x[grid_lines(rig.rows, rig.cols)])
    out.markers += [mesh, seams]
    c = sim.collider_frames(sim.links)
    quats = matrix_to_quat(c.axes)
    for k in range(len(c.centers)):
        m = _marker('colliders', k, Marker.SPHERE, frame, stamp)
        _place(m, c.centers[k], quats[k])
        m.scale.x, m.scale.y, m.scale.z = (2 * c.radii[k]).tolist()
        m.color = GHOST
        out.markers.append(m)
    mid = len(c.centers)
    for a, b, r in zip(c.capsule_a, c.capsule_b, c.capsule_radii):
        # A capsule drawn as its cylinder and two end spheres.
        axis = b - a
        length = float(np.linalg.norm(axis))
        body = _marker('colliders', mid, Marker.CYLINDER, frame, stamp)
        _place(body, (a + b) / 2, _z_to(axis / max(length, 1e-9)))
        body.scale.x = body.scale.y = 2 * float(r)
        body.scale.z = length
        body.color = GHOST
        out.markers.append(body)
        for k, end in enumerate((a, b)):
            cap = _marker('colliders', mid + 1 + k, Marker.SPHERE, frame, stamp)
            _place(cap, end, (0.0, 0.0, 0.0, 1.0))
            cap.scale.x = cap.scale.y = cap.scale.z = 2 * float(r)
            cap.color = GHOST
            out.markers.append(cap)
        mid += 3
    for p, n in zip(c.plane_points, c.plane_normals):
        # A plane drawn as a thin 2 m square around the point nearest the character.
        centre = (p @ n) * n       # the plane's point below the character's root
        tile = _marker('colliders', mid, Marker.CUBE, frame, stamp)
        _place(tile, centre, _z_to(n))
        tile.scale.x = tile.scale.y = 2.0
        tile.scale.z = 0.002
        tile.color = GHOST
        out.markers.append(tile)
        mid += 1
    if sim.layer is not None:
        # M1/M2 layer bones as segments from their pivots to their tips.
        bones = _marker('jacket_bones', 0, Marker.LINE_LIST, frame, stamp)
        bones.scale.x = 0.012
        bones.color = SEAM
        bones.points = _points(np.stack([sim.layer.positions, sim.layer.tips], axis=1).reshape(-1, 3))
        out.markers.append(bones)
    anchor, _ = sim.hood_anchor(sim.links)
    rod = _marker('hood', 0, Marker.LINE_LIST, frame, stamp)
    rod.scale.x = 0.01
    rod.color = HOOD
    rod.points = _points(np.array([anchor, sim.hood_p]))
    bob = _marker('hood', 1, Marker.SPHERE, frame, stamp)
    bob.pose.position.x, bob.pose.position.y, bob.pose.position.z = sim.hood_p.tolist()
    bob.scale.x = bob.scale.y = bob.scale.z = 0.05
    bob.color = HOOD
    out.markers += [rod, bob]
    return out


def diagnostics(stamp_ns, node_name, values, level_warn, message):
    status = DiagnosticStatus()
    status.level = DiagnosticStatus.WARN if level_warn else DiagnosticStatus.OK
    status.name = f'{node_name}: cloth simulation'
    status.message = message
    status.hardware_id = 'jacket_cloth'
    status.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
    out = DiagnosticArray()
    out.header.stamp = stamp_msg(stamp_ns)
    out.status = [status]
    return out
