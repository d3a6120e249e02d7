# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""All fixed steps of one input in one compiled call (numba): JacketSimulation._advance.

Why one call: with each part compiled on its own (pose_kernel, kernel.cloth_step), the Python
between them still cost about three times the 50 us cloth step per step (profiled replay: 190
us per step), and a live node that sleeps between inputs pays it again with cold caches
(measured: the same pipeline took 474 us per input in a tight loop, 811 us with an 8 ms sleep
between inputs). Here the step is the same sequence of the same compiled parts:

  interpolate the skeleton (M7) -> forward kinematics -> M14 world share -> M1/M2 layer ->
  M6 pinned row and M11 references -> colliders (M10) -> cloth (kernel.cloth_step) -> M8 hood.
"""

import numpy as np

from .kernel_cache import njit
from .kernel import cloth_step
from .pose_kernel import (
    _transform_point, collider_poses, forward_kinematics, share_world_motion, skinned_pose,
    solve_layer)

DEEPEST, LIMITED, SWEEPS, SUBSTEPS, NON_FINITE = range(5)       # the ``stats`` slots
STAT_SLOTS = NON_FINITE + 1


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


@njit(cache=True)
def plane_poses(links, root, plane_links, points_local, normals_local, points, normals):
    """Planes on their links; a plane fixed in the world (link < 0) seen from ``root``."""
    frame = np.empty((4, 4))
    for k in range(points.shape[0]):
        if plane_links[k] < 0:
            relative_move(root, np.eye(4), frame)          # world -> the root's local frame
        else:
            frame[:] = links[plane_links[k]]
        _transform_point(frame, points_local[k], points[k])
        for r in range(3):
            normals[k, r] = (frame[r, 0] * normals_local[k, 0] + frame[r, 1] * normals_local[k, 1]
                             + frame[r, 2] * normals_local[k, 2])


@njit(cache=True)
def hood_step(links, hood_link, pivot, length, p, pp, acc, dt, damping):
    """M8: one Verlet particle on a rod of fixed ``length`` from the hood bone's centre."""
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


@njit(cache=True)
def _lost_per(share, exponent):
    """simulation.per_step of one share: lost per design step, as lost per step ``exponent``
    times as long."""
    return share if exponent == 1.0 else 1.0 - (1.0 - share) ** exponent


@njit(cache=True)
def _per_substep(share, exponent, out):
    """simulation.per_step into ``out``: a share lost per design step, per shorter step."""
    for i in range(share.shape[0]):
        out[i] = _lost_per(share[i], exponent)


@njit(cache=True, nogil=True)       # the replay's writer thread runs meanwhile
def advance(q_a, q_b, quat_a, quat_b, pos_a, pos_b, stamp_a, span, t_sim, dt_ns, n,
            origin, axis, kind, var, mult, offset, parent,
            sleeve_link, sleeve_end, sleeve_axis, sleeve_length, sleeve_share, upper,
            pad_pivot, pad_aim_link, pad_aim, pad_length, pad_below_length, down, rest_gap,
            pin_link, pin_local, reference_link, reference_local, pin_below, pin_below_local,
            pin_weight,
            collider_links, centers_local, rotations_local, radii, capsule_links, capsule_ends,
            capsule_radii, plane_links, plane_points_local, plane_normals_local,
            free, con_a, con_b, con_rest, stiffness, iterations, max_distance, limit_mode,
            vert_a, vert_b, vert_rest, tether_anchor, tether_length, solver, max_substeps,
            quality_tolerance, sweep_tolerance, compliance, lam,
            damping, contact_damping, hood_damping, design_exponent,
            world_share, hood_world_share, wind_scale, hood_wind_scale, gravity, wind, gust,
            gust_period,
            hood_link, hood_pivot, hood_length,
            x, xp, contact, hood_p, hood_pp, root, links, before, frames_before,
            layer_rot, layer_pos, layer_tips, below, stats):
    """``n`` fixed steps from sample a towards sample b (as JacketSimulation._step did them).

    The state (x, xp, contact, hood_p, hood_pp, root, links, the frames the last step ended
    with, ``lam``) is updated in place; ``links`` and the layer arrays end with the last
    step's pose (the layer solved in full at that step only). ``stats`` accumulates the
    report's figures. Returns the time of the last step (ns).
    """
    cols = pin_local.shape[0]
    nv = x.shape[0]
    q = np.empty(q_a.shape[0])
    quat = np.empty(4)
    new_root = np.eye(4)
    delta = np.empty((4, 4))
    moved = np.empty(3)
    gravity_l, wind_l = np.empty(3), np.empty(3)
    acc = np.empty((nv, 3))
    hood_acc = np.empty(3)
    top, ref = np.empty((cols, 3)), np.empty((nv, 3))
    centers, axes = np.empty(centers_local.shape), np.empty(rotations_local.shape)
    cap_a = np.empty((capsule_links.shape[0], 3))
    cap_b = np.empty((capsule_links.shape[0], 3))
    plane_p = np.empty(plane_points_local.shape)
    plane_n = np.empty(plane_normals_local.shape)
    c_centers, c_axes, c_cap_a, c_cap_b, c_plane_p, c_plane_n, c_ref = frames_before
    damp = np.empty(nv)
    damp_for = 0
    contact_damp = 0.0
    hood_damp = _lost_per(hood_damping, design_exponent)
    dt = dt_ns * 1e-9
    for step in range(n):
        last = step == n - 1
        t_sim += dt_ns
        # M7: the skeleton between the two samples at this step's time.
        w = min(1.0, max(0.0, (t_sim - stamp_a) / span))
        for k in range(q.shape[0]):
            q[k] = q_a[k] + w * (q_b[k] - q_a[k])
        quat_slerp(quat_a, quat_b, w, quat)
        quat_matrix(quat, new_root)
        for k in range(3):
            new_root[k, 3] = pos_a[k] + w * (pos_b[k] - pos_a[k])
        forward_kinematics(origin, axis, kind, var, mult, offset, parent, q, links)
        # M14: the character moved through the world by `delta` (old local -> new local); a
        # world-space cloth would stay behind by that much. Feel only `world_share` of it.
        relative_move(new_root, root, delta)
        share_world_motion(delta, x, world_share)
        share_world_motion(delta, xp, world_share)
        for point in (hood_p, hood_pp):
            _transform_point(delta, point, moved)
            for k in range(3):
                point[k] += hood_world_share * (moved[k] - point[k])
        root[:] = new_root
        # Gravity and wind (M4, gusts a function of the step's time) in the local frame.
        scale = 1.0
        if gust != 0.0:
            phase = 2 * np.pi * (t_sim * 1e-9) / gust_period
            scale = 1.0 + gust * (0.6 * np.sin(phase) + 0.4 * np.sin(2.7 * phase + 1.3))
        for k in range(3):
            gravity_l[k] = -gravity * root[2, k]
            wind_l[k] = scale * (root[0, k] * wind[0] + root[1, k] * wind[1]
                                 + root[2, k] * wind[2])
        for i in range(nv):
            for k in range(3):
                acc[i, k] = gravity_l[k] + wind_scale[i] * wind_l[k]
        # M2 then M6: the upper jacket is solved, the pinned top row follows it.
        solve_layer(links, sleeve_link, sleeve_end, sleeve_axis, sleeve_length, sleeve_share,
                    upper, pad_pivot, pad_aim_link, pad_aim, pad_length, pad_below_length,
                    down, rest_gap, last, layer_rot, layer_pos, layer_tips, below)
        skinned_pose(links, pin_link, pin_local, reference_link, reference_local, below,
                     pin_below, pin_below_local, pin_weight, top, ref)
        # Substeps: as set, or in the automatic quality mode as few as keep the pinned row's
        # move per substep under the tolerance.
        substeps = max_substeps
        if quality_tolerance > 0.0 and max_substeps > 1:
            move = 0.0
            for c in range(cols):
                for k in range(3):
                    move = max(move, abs(top[c, k] - x[c, k]))
            substeps = int(min(max_substeps, max(1, np.ceil(move / quality_tolerance))))
        pin_from = x.copy() if substeps > 1 else x
        x[:cols] = top
        xp[:cols] = top
        if substeps != damp_for:
            e = design_exponent / substeps
            _per_substep(damping, e, damp)
            contact_damp = _lost_per(contact_damping, e)
            damp_for = substeps
        collider_poses(links, collider_links, centers_local, rotations_local, capsule_links,
                       capsule_ends, centers, axes, cap_a, cap_b)
        plane_poses(links, root, plane_links, plane_points_local, plane_normals_local,
                    plane_p, plane_n)
        if not before[0]:              # no step before: substeps start where this one ends
            c_centers[:], c_axes[:], c_cap_a[:], c_cap_b[:] = centers, axes, cap_a, cap_b
            c_plane_p[:], c_plane_n[:], c_ref[:] = plane_p, plane_n, ref
        deepest, limited, sweeps = cloth_step(
            x, xp, free, acc, damp, contact, contact_damp, dt, con_a, con_b, con_rest,
            stiffness, iterations, centers, axes, radii, cap_a, cap_b, capsule_radii,
            plane_p, plane_n, ref, max_distance, limit_mode, vert_a, vert_b, vert_rest,
            tether_anchor, tether_length, solver, substeps, compliance, lam, pin_from,
            sweep_tolerance, c_centers, c_axes, c_cap_a, c_cap_b, c_plane_p, c_plane_n, c_ref)
        # Where the next step's substeps start from: this step's end.
        c_centers[:], c_axes[:], c_cap_a[:], c_cap_b[:] = centers, axes, cap_a, cap_b
        c_plane_p[:], c_plane_n[:], c_ref[:] = plane_p, plane_n, ref
        before[0] = True
        stats[DEEPEST] = max(stats[DEEPEST], deepest)
        stats[LIMITED] += limited
        stats[SWEEPS] += sweeps
        stats[SUBSTEPS] += substeps
        for k in range(3):
            hood_acc[k] = gravity_l[k] + hood_wind_scale * wind_l[k]
        hood_step(links, hood_link, hood_pivot, hood_length, hood_p, hood_pp, hood_acc, dt,
                  hood_damp)
    if n > 0 and not (np.isfinite(x).all() and np.isfinite(hood_p).all()):
        stats[NON_FINITE] = 1.0
    return t_sim
