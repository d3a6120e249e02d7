# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The skeleton's pose and the bones' frames (numba): kinematics, M1/M2 layer, skinning, M9.

Why compiled: at the shipped rig's size each of these is a few dozen small numpy calls, and
numpy's per-call overhead, not arithmetic, made them cost several times the cloth step itself
(docs/performance.md). Same formulas as ``transforms``; tests hold them equal.
"""

import numpy as np

from ..compiled import njit

FIXED, ROTATION, TRANSLATION = -1, 0, 1      # Skeleton.kind


@njit(cache=True)
def rodrigues(axis, angle, m):
    """Rotation by ``angle`` about the unit ``axis`` into ``m`` (3,3)."""
    _rodrigues(axis[0], axis[1], axis[2], angle, m)


@njit(cache=True)
def _rodrigues(x, y, z, angle, m):
    """Rotation by ``angle`` about the unit axis (``x``, ``y``, ``z``) into ``m`` (3,3)."""
    c, s = np.cos(angle), np.sin(angle)
    t = 1.0 - c
    m[0, 0], m[0, 1], m[0, 2] = c + x * x * t, x * y * t - z * s, x * z * t + y * s
    m[1, 0], m[1, 1], m[1, 2] = y * x * t + z * s, c + y * y * t, y * z * t - x * s
    m[2, 0], m[2, 1], m[2, 2] = z * x * t - y * s, z * y * t + x * s, c + z * z * t


@njit(cache=True)
def _matmul3(a, b, out):
    for r in range(3):
        for c in range(3):
            out[r, c] = a[r, 0] * b[0, c] + a[r, 1] * b[1, c] + a[r, 2] * b[2, c]


@njit(cache=True)
def _transform_point(t, p, out):
    for r in range(3):
        out[r] = t[r, 0] * p[0] + t[r, 1] * p[1] + t[r, 2] * p[2] + t[r, 3]


@njit(cache=True)
def _rotate(t, v, out):
    for r in range(3):
        out[r] = t[r, 0] * v[0] + t[r, 1] * v[1] + t[r, 2] * v[2]


@njit(cache=True)
def forward_kinematics(skeleton, q, world):
    """Put the link transforms of a bundles.SkeletonModel into ``world`` (L,4,4), root frame.

    Links are in breadth-first order.
    """
    origin, axis, kind, var = skeleton.origin, skeleton.axis, skeleton.kind, skeleton.var
    mult, offset, parent = skeleton.mult, skeleton.offset, skeleton.parent
    local = np.empty((4, 4))
    m = np.empty((3, 3))
    # Indexed, not sliced: each view of a row is an atomic reference count in and out, per
    # link and step.
    for r in range(4):
        for col in range(4):
            world[0, r, col] = 1.0 if r == col else 0.0
    for k in range(1, origin.shape[0]):
        for r in range(4):
            for col in range(4):
                local[r, col] = origin[k, r, col]
        v = q[var[k]] * mult[k] + offset[k] if var[k] >= 0 else 0.0
        if kind[k] == ROTATION:
            _rodrigues(axis[k, 0], axis[k, 1], axis[k, 2], v, m)
            for r in range(3):      # origin's rotation times m (_matmul3)
                for col in range(3):
                    local[r, col] = (origin[k, r, 0] * m[0, col] + origin[k, r, 1] * m[1, col]
                                     + origin[k, r, 2] * m[2, col])
        elif kind[k] == TRANSLATION:
            for r in range(3):
                local[r, 3] += (origin[k, r, 0] * axis[k, 0] + origin[k, r, 1] * axis[k, 1]
                                + origin[k, r, 2] * axis[k, 2]) * v
        p = parent[k]
        for r in range(4):               # world[k] = world[parent] @ local (no BLAS in numba)
            for col in range(4):
                world[k, r, col] = (world[p, r, 0] * local[0, col] + world[p, r, 1] * local[1, col]
                                    + world[p, r, 2] * local[2, col]
                                    + world[p, r, 3] * local[3, col])


@njit(cache=True)
def quat_from_matrix(r, out):
    """One rotation to a unit quaternion (x, y, z, w), w >= 0 (as transforms.matrix_to_quat)."""
    m00, m11, m22 = r[0, 0], r[1, 1], r[2, 2]
    x = 0.5 * np.sqrt(max(0.0, 1.0 + m00 - m11 - m22))
    y = 0.5 * np.sqrt(max(0.0, 1.0 - m00 + m11 - m22))
    z = 0.5 * np.sqrt(max(0.0, 1.0 - m00 - m11 + m22))
    w = 0.5 * np.sqrt(max(0.0, 1.0 + m00 + m11 + m22))
    x = np.copysign(x, r[2, 1] - r[1, 2])
    y = np.copysign(y, r[0, 2] - r[2, 0])
    z = np.copysign(z, r[1, 0] - r[0, 1])
    n = np.sqrt(x * x + y * y + z * z + w * w)
    out[0], out[1], out[2], out[3] = x / n, y / n, z / n, w / n


@njit(cache=True)
def orthonormal_frame(xa, ya, out):
    """Columns x, y, z from rough x and y axes (shear removed), into ``out`` (3,3)."""
    n = np.sqrt(xa[0] * xa[0] + xa[1] * xa[1] + xa[2] * xa[2])
    x0, x1, x2 = xa[0] / n, xa[1] / n, xa[2] / n
    z0 = x1 * ya[2] - x2 * ya[1]
    z1 = x2 * ya[0] - x0 * ya[2]
    z2 = x0 * ya[1] - x1 * ya[0]
    n = np.sqrt(z0 * z0 + z1 * z1 + z2 * z2)
    z0, z1, z2 = z0 / n, z1 / n, z2 / n
    out[0, 0], out[1, 0], out[2, 0] = x0, x1, x2
    out[0, 1], out[1, 1], out[2, 1] = z1 * x2 - z2 * x1, z2 * x0 - z0 * x2, z0 * x1 - z1 * x0
    out[0, 2], out[1, 2], out[2, 2] = z0, z1, z2


# A grid edge shorter than this (m) has no direction: rows of the hem pressed flat together.
EDGE_NO_LENGTH = 1e-7
# Down and across closer to parallel than this sine make no frame.
PARALLEL_SINE = 1e-4


@njit(cache=True)
def _offset(k):
    """Return the k-th of 0, 1, -1, 2, -2, ...: the nearest first, on either side."""
    return (k + 1) // 2 if k % 2 == 1 else -(k // 2)


@njit(cache=True)
def _grid_down(x, cols, rows, r, c, out):
    """Down the cloth at grid vertex (r, c) into ``out``; return whether it has a direction.

    Its own vertical edge, else the nearest one with a length: its column's edges above and
    below first, then the neighbouring columns'.
    """
    for d in range(rows + cols):
        for k in range(2 * min(d, cols) + 1):
            dc = _offset(k)
            if abs(dc) > d:
                break
            cc = c + dc
            dr = d - abs(dc)
            if cc < 0 or cc >= cols:
                continue
            for rr in (r + dr, r - dr):
                if rr < 0 or rr >= rows - 1:
                    continue
                n2 = 0.0
                for j in range(3):
                    out[j] = x[(rr + 1) * cols + cc, j] - x[rr * cols + cc, j]
                    n2 += out[j] * out[j]
                # A non-finite edge is taken as it is: its NaN reaches the bones, and the
                # caller resets a non-finite state instead of hiding it.
                if not n2 <= EDGE_NO_LENGTH * EDGE_NO_LENGTH:
                    return True
    return False


@njit(cache=True)
def _grid_across(x, cols, rows, r, c, down, out):
    """Across the cloth at grid vertex (r, c), not along ``down``, into ``out``.

    Returns whether there is one: its row's edge from the left neighbour to the right one, else
    the nearest such edge of the rows above and below, then of the neighbouring columns.
    """
    dn = np.sqrt(down[0] * down[0] + down[1] * down[1] + down[2] * down[2])
    for d in range(rows + cols):
        for k in range(2 * min(d, cols) + 1):
            dc = _offset(k)
            if abs(dc) > d:
                break
            cc = c + dc
            dr = d - abs(dc)
            if cc < 0 or cc >= cols:
                continue
            for rr in (r + dr, r - dr):
                if rr < 0 or rr >= rows:
                    continue
                left, right = rr * cols + max(cc - 1, 0), rr * cols + min(cc + 1, cols - 1)
                for j in range(3):
                    out[j] = x[right, j] - x[left, j]
                z0 = down[1] * out[2] - down[2] * out[1]
                z1 = down[2] * out[0] - down[0] * out[2]
                z2 = down[0] * out[1] - down[1] * out[0]
                n = np.sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2])
                if not np.isfinite(n) or not np.isfinite(dn):
                    return True
                if (n > EDGE_NO_LENGTH
                        and np.sqrt(z0 * z0 + z1 * z1 + z2 * z2) > PARALLEL_SINE * n * dn):
                    return True
    return False


@njit(cache=True)
def grid_bones(x, cols, bone_rc, positions, quaternions):
    """M9: a bone per chosen grid vertex, x down its column, y across its row.

    An edge pressed to no length (the hem flattened between the body and the floor) gives its
    bone no direction: the nearest edges that have one give it, and where none does the bone
    keeps the rotation ``quaternions`` holds (the last good one), so bones stay finite.
    """
    frame = np.empty((3, 3))
    xa = np.empty(3)
    ya = np.empty(3)
    rows = x.shape[0] // cols
    for b in range(bone_rc.shape[0]):
        r, c = bone_rc[b, 0], bone_rc[b, 1]
        i = r * cols + c
        for k in range(3):
            positions[b, k] = x[i, k]
        if _grid_down(x, cols, rows, r, c, xa) and _grid_across(x, cols, rows, r, c, xa, ya):
            orthonormal_frame(xa, ya, frame)
            quat_from_matrix(frame, quaternions[b])


@njit(cache=True)
def bone_poses(x, hood_p, links, cloth, bone_rc, layer_parents, layer_rot, layer_pos, poses):
    """Pose every bone relative to its parent link into ``poses`` (B,7), as bones() gives them.

    M9 grid bones of the bundles.ClothModel's grid in the root frame, then the M8 hood bone
    (y towards the body's left, the hood's side in its link's frame) and the M1/M2 layer bones
    on their links. Returns whether every number is finite.
    """
    positions, quaternions = poses[:, :3], poses[:, 3:]
    n_grid = bone_rc.shape[0]
    grid_bones(x, cloth.pin_local.shape[0], bone_rc, positions[:n_grid], quaternions[:n_grid])
    t = links[cloth.hood_link]
    anchor, frame, local, side = np.empty(3), np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
    _transform_point(t, cloth.hood_pivot, anchor)
    _rotate(t, cloth.hood_side, side)
    orthonormal_frame(hood_p - anchor, side, frame)
    _to_link(t, anchor, frame, positions[n_grid], local)
    quat_from_matrix(local, quaternions[n_grid])
    for b in range(layer_parents.shape[0]):
        _to_link(links[layer_parents[b]], layer_pos[b], layer_rot[b],
                 positions[n_grid + 1 + b], local)
        quat_from_matrix(local, quaternions[n_grid + 1 + b])
    return np.isfinite(positions).all() and np.isfinite(quaternions).all()


@njit(cache=True)
def kept_bone_poses(x, hood_p, links, cloth, bone_rc, layer_parents, layer_rot, layer_pos, poses):
    """bone_poses, but the grid rotations ``poses`` held stay if not every number is finite.

    A grid bone whose edges lie flat keeps its last finite rotation (grid_bones): a failed
    pose must not become that rotation. A degenerate frame (numba raises where numpy gives
    NaN) is not finite either.
    """
    n_grid = bone_rc.shape[0]
    kept = poses[:n_grid, 3:].copy()
    try:
        finite = bone_poses(x, hood_p, links, cloth, bone_rc, layer_parents, layer_rot,
                            layer_pos, poses)
    except Exception:  # noqa: BLE001 - numba names no exception object; only division raises
        finite = False
    if not finite:
        poses[:n_grid, 3:] = kept
    return finite


@njit(cache=True)
def _to_link(t, position, rotation, local_position, local_rotation):
    """Return a frame (position, rotation) in the root frame, seen from link pose ``t``."""
    for r in range(3):
        local_position[r] = (t[0, r] * (position[0] - t[0, 3]) + t[1, r] * (position[1] - t[1, 3])
                             + t[2, r] * (position[2] - t[2, 3]))
        for c in range(3):
            local_rotation[r, c] = (t[0, r] * rotation[0, c] + t[1, r] * rotation[1, c]
                                    + t[2, r] * rotation[2, c])


@njit(cache=True)
def twist_angle(rotation, axis):
    """Return the twist of ``rotation`` about the unit ``axis`` (swing-twist split), radians."""
    w = np.sqrt(max(0.0, 1.0 + rotation[0, 0] + rotation[1, 1] + rotation[2, 2])) / 2
    if w > 1e-6:
        v0 = (rotation[2, 1] - rotation[1, 2]) / (4 * w)
        v1 = (rotation[0, 2] - rotation[2, 0]) / (4 * w)
        v2 = (rotation[1, 0] - rotation[0, 1]) / (4 * w)
    else:                                # a half turn: its axis from the largest diagonal
        k = np.argmax(np.array([rotation[0, 0], rotation[1, 1], rotation[2, 2]]))
        v0, v1, v2 = rotation[0, k] / 2, rotation[1, k] / 2, rotation[2, k] / 2
        if k == 0:
            v0 += 0.5
        elif k == 1:
            v1 += 0.5
        else:
            v2 += 0.5
        n = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        v0, v1, v2 = v0 / n, v1 / n, v2 / n
    return 2 * np.arctan2(v0 * axis[0] + v1 * axis[1] + v2 * axis[2], w)


@njit(cache=True)
def _followed(angle, last):
    """Return ``angle`` (within half a turn of zero) taken within half a turn of ``last``.

    A twist is known only up to whole turns: a wrist rolled on past a half turn must not flip
    its sleeve's twist bone to the other side. NaN ``last``: ``angle`` as it is.
    """
    turns = np.floor((last - angle) / (2 * np.pi) + 0.5)
    if turns != 0.0 and np.isfinite(turns):
        return angle + 2 * np.pi * turns
    return angle


@njit(cache=True)
def solve_layer(links, layer, full, rot, pos, tips, below, twist):
    """Solve M1 sleeves and M2 pads of a bundles.LayerModel (see bone_layer.BoneLayer.solve).

    Bones go into rot/pos/tips in the layer's order when ``full``, and the bones below the pads
    always into ``below``. ``twist``: each sleeve's twist at the last full solve (NaN: none),
    moved on to this one's.
    """
    sleeve_link, sleeve_end, sleeve_axis = layer.sleeve_link, layer.sleeve_end, layer.sleeve_axis
    sleeve_length, sleeve_share, upper = layer.sleeve_length, layer.sleeve_share, layer.upper
    sleeve_rest = layer.sleeve_rest
    pad_pivot, pad_aim_link, pad_aim = layer.pad_pivot, layer.pad_aim_link, layer.pad_aim
    pad_length, pad_below_length = layer.pad_length, layer.pad_below_length
    down, side, rest_gap = layer.down, layer.side, layer.rest_gap
    n_s = sleeve_link.shape[0]
    b = 0
    m = np.empty((3, 3))
    rel = np.empty((3, 3))
    turn = np.empty((3, 3))
    if full:
        for i in range(n_s):
            t = links[sleeve_link[i]]
            rot[b] = t[:3, :3]
            pos[b] = t[:3, 3]
            tips[b] = links[sleeve_end[i], :3, 3]
            b += 1
        for i in range(n_s):
            t, end = links[sleeve_link[i]], links[sleeve_end[i]]
            # The end link's turn since the zero pose, seen from the link: its frame's own
            # axes at rest do not count as twist.
            _matmul3(t[:3, :3].T, end[:3, :3], turn)
            _matmul3(turn, sleeve_rest[i], rel)
            angle = _followed(twist_angle(rel, sleeve_axis[i]), twist[i])
            twist[i] = angle
            rodrigues(sleeve_axis[i], sleeve_share[i] * angle, m)
            _matmul3(t[:3, :3], m, rot[b])
            for r in range(3):
                pos[b, r] = t[r, 3] + 0.5 * sleeve_length[i] * (
                    t[r, 0] * sleeve_axis[i, 0] + t[r, 1] * sleeve_axis[i, 1]
                    + t[r, 2] * sleeve_axis[i, 2])
            tips[b] = end[:3, 3]
            b += 1
    n_p = pad_pivot.shape[0]
    if n_p == 0:
        return
    torso = links[upper]
    ends = np.empty((n_p, 3))
    frame = np.empty((3, 3))
    pivot, target, left = np.empty(3), np.empty(3), np.empty(3)
    _rotate(torso, side, left)
    for k in range(n_p):
        _transform_point(torso, pad_pivot[k], pivot)
        _transform_point(links[pad_aim_link[k]], pad_aim[k], target)
        orthonormal_frame(target - pivot, left, frame)      # M2 look-at
        ends[k] = pivot + pad_length[k] * frame[:, 0]
        if full:
            rot[b] = frame
            pos[b] = pivot
            tips[b] = ends[k]
            b += 1
    # Left/right position constraint: each bone below moves half the error.
    gap_v = ends[1] - ends[0]
    gap = np.sqrt(gap_v[0] ** 2 + gap_v[1] ** 2 + gap_v[2] ** 2)
    if gap > 1e-9:
        corr = 0.5 * (gap - rest_gap) / gap * gap_v
        ends[0] += corr
        ends[1] -= corr
    _matmul3(torso[:3, :3], down, m)
    for k in range(n_p):
        if full:
            rot[b] = m
            pos[b] = ends[k]
            tips[b] = ends[k] + m[:, 0] * pad_below_length[k]
            b += 1
        below[k] = np.eye(4)
        below[k, :3, :3] = m
        below[k, :3, 3] = ends[k]


@njit(cache=True)
def skinned_pose(links, cloth, below, top, ref):
    """Pose the M6 pinned top row and M11 reference points of a bundles.ClothModel.

    See JacketSimulation._skinned_pose. The top row rides its link, blended towards the M2
    bones below the pads (``below``, none when empty); each column's reference points are
    lifted with its top vertex.
    """
    pin_link, pin_local = cloth.pin_link, cloth.pin_local
    reference_link, reference_local = cloth.reference_link, cloth.reference_local
    pin_below, pin_below_local, pin_weight = (cloth.pin_below, cloth.pin_below_local,
                                              cloth.pin_weight)
    cols = pin_local.shape[0]
    carried = np.empty(3)
    held = np.empty(3)
    for i in range(ref.shape[0]):
        _transform_point(links[reference_link[i]], reference_local[i], ref[i])
    for c in range(cols):
        _transform_point(links[pin_link], pin_local[c], carried)
        if below.shape[0] == 0:
            top[c] = carried
            continue
        _transform_point(below[pin_below[c]], pin_below_local[c], held)
        w = pin_weight[c]
        for k in range(3):
            top[c, k] = (1.0 - w) * carried[k] + w * held[k]
            lift = top[c, k] - carried[k]
            for i in range(c, ref.shape[0], cols):
                ref[i, k] += lift


@njit(cache=True)
def share_world_motion(delta, points, share):
    """M14: move each point by its share of the rigid move ``delta`` (4x4) of the frame."""
    moved = np.empty(3)
    for i in range(points.shape[0]):
        _transform_point(delta, points[i], moved)
        s = share[i]
        for k in range(3):
            points[i, k] += s * (moved[k] - points[i, k])


@njit(cache=True)
def quat_slerp(q0, q1, t, out):
    """As transforms.quat_slerp, into ``out``."""
    d = q0[0] * q1[0] + q0[1] * q1[1] + q0[2] * q1[2] + q0[3] * q1[3]
    sign = 1.0
    if d < 0.0:
        sign, d = -1.0, -d
    if d > 0.9995:
        for k in range(4):
            out[k] = q0[k] + t * (sign * q1[k] - q0[k])
        n = np.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2 + out[3] ** 2)
        for k in range(4):
            out[k] /= n
        return
    theta = np.arccos(d)
    s = np.sin(theta)
    a, b = np.sin((1 - t) * theta), np.sin(t * theta)
    for k in range(4):
        out[k] = (a * q0[k] + b * sign * q1[k]) / s


@njit(cache=True)
def quat_matrix(q, out):
    """As transforms.quat_to_matrix (normalising), into the top-left 3x3 of ``out``."""
    n = np.sqrt(q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    x, y, z, w = q[0] / n, q[1] / n, q[2] / n, q[3] / n
    out[0, 0] = 1 - 2 * (y * y + z * z)
    out[0, 1] = 2 * (x * y - z * w)
    out[0, 2] = 2 * (x * z + y * w)
    out[1, 0] = 2 * (x * y + z * w)
    out[1, 1] = 1 - 2 * (x * x + z * z)
    out[1, 2] = 2 * (y * z - x * w)
    out[2, 0] = 2 * (x * z - y * w)
    out[2, 1] = 2 * (y * z + x * w)
    out[2, 2] = 1 - 2 * (x * x + y * y)


@njit(cache=True)
def relative_move(new, old, delta):
    """``delta`` = inverse(new) @ old for rigid 4x4 transforms: old local -> new local."""
    delta[:] = 0.0
    delta[3, 3] = 1.0
    for r in range(3):
        for c in range(3):
            delta[r, c] = new[0, r] * old[0, c] + new[1, r] * old[1, c] + new[2, r] * old[2, c]
        delta[r, 3] = (new[0, r] * (old[0, 3] - new[0, 3]) + new[1, r] * (old[1, 3] - new[1, 3])
                       + new[2, r] * (old[2, 3] - new[2, 3]))
