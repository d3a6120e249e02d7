# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""M1: the jacket as a skinned mesh on the bone layer, compiled (linear blend skinning).

Why compiled: the mesh is skinned, shaded and laid out as triangles for every markers message;
in numpy that is a dozen temporaries per call, several times the cost of one pass here.
"""

import numpy as np

from ..compiled import njit
from .colliders import plane_pose


@njit(cache=True, nogil=True)
def joint_matrices(links, parents, poses, out):
    """Every joint of a mesh in the simulation frame: the links, then the bones on their parents.

    :param links: (L,4,4) link transforms.
    :param parents: (B,) each bone's parent link.
    :param poses: (B,7) each bone's pose in its parent's frame (translation, quaternion x y z w).
    :param out: (L+B,3,4) written: rotation and translation of every joint.
    """
    n_links = links.shape[0]
    for j in range(n_links):
        out[j] = links[j, :3, :]
    r = np.empty((3, 3))
    for b in range(parents.shape[0]):
        x, y, z, w = poses[b, 3], poses[b, 4], poses[b, 5], poses[b, 6]
        r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - z * w), \
            2 * (x * z + y * w)
        r[1, 0], r[1, 1], r[1, 2] = 2 * (x * y + z * w), 1 - 2 * (x * x + z * z), \
            2 * (y * z - x * w)
        r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - y * w), 2 * (y * z + x * w), \
            1 - 2 * (x * x + y * y)
        t = links[parents[b]]
        j = n_links + b
        for i in range(3):
            for k in range(3):
                out[j, i, k] = t[i, 0] * r[0, k] + t[i, 1] * r[1, k] + t[i, 2] * r[2, k]
            out[j, i, 3] = (t[i, 0] * poses[b, 0] + t[i, 1] * poses[b, 1] + t[i, 2] * poses[b, 2]
                            + t[i, 3])


@njit(cache=True, nogil=True)
def skin(joints_now, inverse_rest, joints, weights, rest, out):
    """Linear blend skinning: ``out[v] = sum_k w[v,k] M[j] inverse_rest[j] rest[v]``.

    :param joints_now: (J,3,4) the joints now (joint_matrices).
    :param inverse_rest: (J,3,4) each joint's inverse at rest.
    :param joints: (V,K) int64 joint of each influence.
    :param weights: (V,K) each influence's weight (a row sums to one).
    :param rest: (V,3) the rest mesh.
    :param out: (V,3) written.
    """
    n_joints = joints_now.shape[0]
    skin_m = np.empty((n_joints, 3, 4))
    for j in range(n_joints):        # M inverse_rest, once per joint rather than per influence
        a, b = joints_now[j], inverse_rest[j]
        for i in range(3):
            for k in range(4):
                s = a[i, 0] * b[0, k] + a[i, 1] * b[1, k] + a[i, 2] * b[2, k]
                skin_m[j, i, k] = s + a[i, 3] if k == 3 else s
    for v in range(rest.shape[0]):
        px, py, pz = rest[v, 0], rest[v, 1], rest[v, 2]
        ox = oy = oz = 0.0
        for k in range(joints.shape[1]):
            w = weights[v, k]
            if w == 0.0:
                continue
            m = skin_m[joints[v, k]]
            ox += w * (m[0, 0] * px + m[0, 1] * py + m[0, 2] * pz + m[0, 3])
            oy += w * (m[1, 0] * px + m[1, 1] * py + m[1, 2] * pz + m[1, 3])
            oz += w * (m[2, 0] * px + m[2, 1] * py + m[2, 2] * pz + m[2, 3])
        out[v, 0], out[v, 1], out[v, 2] = ox, oy, oz


@njit(cache=True, nogil=True)
def vertex_normals(points, triangles, out):
    """Area-weighted unit normals of a triangle mesh's vertices (zero where no area).

    :param points: (V,3) the vertices.
    :param triangles: (T,3) int64, counter-clockwise seen from outside.
    :param out: (V,3) written.
    """
    out[:] = 0.0
    for t in range(triangles.shape[0]):
        a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
        e1x, e1y, e1z = points[b, 0] - points[a, 0], points[b, 1] - points[a, 1], \
            points[b, 2] - points[a, 2]
        e2x, e2y, e2z = points[c, 0] - points[a, 0], points[c, 1] - points[a, 1], \
            points[c, 2] - points[a, 2]
        nx, ny, nz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        for v in (a, b, c):
            out[v, 0] += nx
            out[v, 1] += ny
            out[v, 2] += nz
    for v in range(points.shape[0]):
        n = np.sqrt(out[v, 0] ** 2 + out[v, 1] ** 2 + out[v, 2] ** 2)
        if n > 1e-12:
            out[v, 0] /= n
            out[v, 1] /= n
            out[v, 2] /= n


@njit(cache=True, nogil=True)
def shaded_triangles(points, normals, triangles, colors, back, light, ambient, lining_gap,
                     out_points, out_colors):
    """Lay a mesh out as a triangle list with a shaded colour per corner.

    Lambert shading from one light plus an ambient share, so folds read in viewers that draw
    triangle lists unlit. A back face (``back[t]``) is the same triangle wound the other way
    with the normal turned, the jacket's lining seen from inside. It lies ``lining_gap``
    inside the front face: viewers that draw both sides of a triangle (RViz, Foxglove) would
    otherwise show the two faces flickering through each other.

    :param points: (V,3) the skinned vertices.
    :param normals: (V,3) their unit normals.
    :param triangles: (T,3) int64 corners.
    :param colors: (T,4) each triangle's base colour (RGBA).
    :param back: (T,) bool: the triangle is a back face.
    :param light: (3,) unit direction towards the light.
    :param ambient: the share of the colour lit from everywhere.
    :param lining_gap: how far a back face lies inside its front face, along the normal.
    :param out_points: (3T,3) written: the corners in triangle-list order.
    :param out_colors: (3T,4) float32 written: each corner's shaded colour.
    """
    n = points.shape[0]
    # Lit and placed once per vertex and side, not per corner (a vertex has six corners).
    lit = np.empty((2, n))
    inner = np.empty((n, 3))
    for v in range(n):
        d = normals[v, 0] * light[0] + normals[v, 1] * light[1] + normals[v, 2] * light[2]
        lit[0, v] = ambient + (1.0 - ambient) * max(d, 0.0)
        lit[1, v] = ambient + (1.0 - ambient) * max(-d, 0.0)
        for i in range(3):
            inner[v, i] = points[v, i] - lining_gap * normals[v, i]
    for t in range(triangles.shape[0]):
        side = 1 if back[t] else 0
        source = inner if back[t] else points
        r, g, b, a = colors[t, 0], colors[t, 1], colors[t, 2], colors[t, 3]
        for k in range(3):
            v = triangles[t, k]
            row = 3 * t + k
            out_points[row, 0] = source[v, 0]
            out_points[row, 1] = source[v, 1]
            out_points[row, 2] = source[v, 2]
            shade = lit[side, v]
            out_colors[row, 0] = r * shade
            out_colors[row, 1] = g * shade
            out_colors[row, 2] = b * shade
            out_colors[row, 3] = a


@njit(cache=True, nogil=True)
def draw(mesh, joints_now, light, ambient, lining_gap, out_points, out_colors):
    """Skin a bundles.MeshModel on ``joints_now``, shade it and lay it out as a triangle list.

    skin, vertex_normals and shaded_triangles in one call: a markers message's mesh, whose
    arguments typed three times in Python cost as much as a third of the work.

    :param mesh: the mesh.
    :param joints_now: (J,3,4) its joints now (joint_matrices; extra rows are not read).
    :param light: (3,) unit direction towards the light.
    :param ambient: the share of the colour lit from everywhere.
    :param lining_gap: how far a back face lies inside its front face.
    :param out_points: (3T,3) written: the corners in triangle-list order.
    :param out_colors: (3T,4) float32 written: each corner's shaded colour.
    """
    _laid_out(mesh, _skinned(mesh, joints_now), light, ambient, lining_gap, out_points,
              out_colors)


@njit(cache=True, nogil=True)
def _skinned(mesh, joints_now):
    """Return a bundles.MeshModel's vertices skinned on ``joints_now``."""
    where = np.empty(mesh.rest.shape)
    skin(joints_now[:mesh.inverse_rest.shape[0]], mesh.inverse_rest, mesh.joints, mesh.weights,
         mesh.rest, where)
    return where


@njit(cache=True, nogil=True)
def _laid_out(mesh, where, light, ambient, lining_gap, out_points, out_colors):
    """Shade a mesh's skinned vertices ``where`` and lay them out as :func:`draw` does."""
    normals = np.empty(where.shape)
    vertex_normals(where, mesh.front, normals)
    shaded_triangles(where, normals, mesh.triangles, mesh.colors, mesh.back, light, ambient,
                     lining_gap, out_points, out_colors)


@njit(cache=True, nogil=True)
def above_planes(points, links, planes):
    """Move each point behind one of a rig's planes onto it, along the plane's unit normal.

    The jacket a viewer sees is skinned between the cloth's particles and bones: where the
    particles lie on the floor, the smoothed mesh between them reached under it. Every part
    is held, the sleeves, yoke and hood too, as the cloth's particles and the hood's are.

    :param points: (V,3) moved in place.
    :param links: (L,4,4) the links the planes ride on.
    :param planes: (root, plane_links, plane_points, plane_normals): the root's (4,4) pose in
        the world and a bundles.ColliderModel's planes (link -1: fixed in the world; normals
        of unit length, as the rig makes them).
    """
    root, plane_links, plane_points, plane_normals = planes
    frame, p, n = np.empty((4, 4)), np.empty(3), np.empty(3)
    for k in range(plane_links.shape[0]):
        plane_pose(links, root, plane_links[k], plane_points[k], plane_normals[k], frame, p, n)
        for v in range(points.shape[0]):
            d = ((points[v, 0] - p[0]) * n[0] + (points[v, 1] - p[1]) * n[1]
                 + (points[v, 2] - p[2]) * n[2])
            if d < 0.0:
                for i in range(3):
                    points[v, i] -= d * n[i]


@njit(cache=True, nogil=True)
def draw_posed(mesh, links, parents, poses, light, ambient, lining_gap, planes, out_points,
               out_colors):
    """:func:`draw` on the joints of ``links`` and bone ``poses`` (joint_matrices), one call.

    The skinned vertices are held out of the rig's ``planes`` first (:func:`above_planes`).

    :param mesh: the mesh (a bundles.MeshModel).
    :param links: (L,4,4) link transforms.
    :param parents: (B,) each bone's parent link.
    :param poses: (B,7) each bone's pose in its parent's frame.
    :param light: (3,) unit direction towards the light.
    :param ambient: the share of the colour lit from everywhere.
    :param lining_gap: how far a back face lies inside its front face.
    :param planes: as :func:`above_planes` takes them; no planes: nothing held.
    :param out_points: (3T,3) written: the corners in triangle-list order.
    :param out_colors: (3T,4) float32 written: each corner's shaded colour.
    """
    joints_now = np.empty((links.shape[0] + parents.shape[0], 3, 4))
    joint_matrices(links, parents, poses, joints_now)
    where = _skinned(mesh, joints_now)
    above_planes(where, links, planes)
    _laid_out(mesh, where, light, ambient, lining_gap, out_points, out_colors)
