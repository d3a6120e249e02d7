# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""All fixed steps of one input in one compiled call (numba): JacketSimulation._advance.

Why one call: with each part compiled on its own (pose_kernel, kernel.cloth_step), the Python
between them still cost several times the cloth step, and a live node that sleeps between
inputs pays it again with cold caches (docs/performance.md). Here the step is the same
sequence of the same compiled parts:

  interpolate the skeleton (M7) -> forward kinematics -> M14 world share -> M1/M2 layer ->
  M6 pinned row and M11 references -> colliders (M10), the pinned row kept outside them ->
  cloth (kernel.cloth_step) -> M8 hood.
"""

import numpy as np

from .bundles import Posed, StepControl
from .kernel_cache import njit
from .kernel import cloth_step, hold_pinned_row, push_out_points
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
def plane_poses(links, root, colliders, posed):
    """Pose the planes of a bundles.ColliderModel on their links into a bundles.Posed.

    A plane fixed in the world (link < 0) is seen from ``root``.
    """
    plane_links, points_local = colliders.plane_links, colliders.plane_points
    normals_local, points, normals = colliders.plane_normals, posed.plane_p, posed.plane_n
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


@njit(cache=True)
def lost_per(share, exponent):
    """Return a share lost per design step as the share lost in a step ``exponent`` times as long.

    Fabrics are tuned at simulation.DESIGN_RATE.
    """
    return share if exponent == 1.0 else 1.0 - (1.0 - share) ** exponent


@njit(cache=True)
def lost_per_each(share, exponent, out):
    """lost_per of each share into ``out``."""
    for i in range(share.shape[0]):
        out[i] = lost_per(share[i], exponent)


@njit(cache=True, nogil=True)       # the replay's writer thread runs meanwhile
def advance(model, tuning, state, before, motion, out):
    """Run ``motion.steps`` fixed steps from sample a towards sample b.

    Takes core.bundles: Model, Tuning, ClothState, Posed, Motion, StepOutput.
    ``state`` is moved in place; ``before`` holds the colliders and references where the
    last step ended and is moved on to this one's end; ``out.links`` and the layer arrays
    end with the last step's pose (the layer solved in full at that step only).
    ``out.stats`` accumulates the report's figures. Returns the time of the last step (ns).
    """
    cloth, colliders = model.cloth, model.colliders
    x, xp, hood_p, hood_pp, root = state.x, state.xp, state.hood_p, state.hood_pp, state.root
    links, stats, below = out.links, out.stats, out.below
    cols = cloth.pin_local.shape[0]
    nv = x.shape[0]
    q = np.empty(motion.q_a.shape[0])
    quat = np.empty(4)
    new_root = np.eye(4)
    delta = np.empty((4, 4))
    moved = np.empty(3)
    gravity_l, wind_l = np.empty(3), np.empty(3)
    acc = np.empty((nv, 3))
    hood_acc = np.empty(3)
    top = np.empty((cols, 3))
    k_caps = colliders.capsule_links.shape[0]
    now = Posed(np.empty(colliders.centers.shape), np.empty(colliders.rotations.shape),
                np.empty((k_caps, 3)), np.empty((k_caps, 3)),
                np.empty(colliders.plane_points.shape), np.empty(colliders.plane_normals.shape),
                np.empty((nv, 3)))
    damp = np.empty(nv)
    ride = np.empty((nv, 3))
    damp_for = 0
    contact_damp = 0.0
    hood_damp = lost_per(tuning.hood_damping, tuning.design_exponent)
    dt_ns = motion.dt_ns
    dt = dt_ns * 1e-9
    t_sim = motion.t_sim
    gust, wind = tuning.gust, tuning.wind
    for step in range(motion.steps):
        last = step == motion.steps - 1
        t_sim += dt_ns
        # M7: the skeleton between the two samples at this step's time.
        w = min(1.0, max(0.0, (t_sim - motion.stamp_a) / motion.span))
        for k in range(q.shape[0]):
            q[k] = motion.q_a[k] + w * (motion.q_b[k] - motion.q_a[k])
        quat_slerp(motion.quat_a, motion.quat_b, w, quat)
        quat_matrix(quat, new_root)
        for k in range(3):
            new_root[k, 3] = motion.pos_a[k] + w * (motion.pos_b[k] - motion.pos_a[k])
        forward_kinematics(model.skeleton, q, links)
        # Level of detail: the share of the riding cloth (core/lod.py) and, riding, each
        # vertex's offset from its column's top before the world share moves it.
        skin = tuning.skin_from + (tuning.skin_to - tuning.skin_from) * (step + 1.0) \
            / motion.steps
        if skin > 0.0:
            for i in range(cols, nv):
                for k in range(3):
                    ride[i, k] = x[i, k] - x[i % cols, k]
        # M14: the character moved through the world by `delta` (old local -> new local); a
        # world-space cloth would stay behind by that much. Feel only `world_share` of it.
        relative_move(new_root, root, delta)
        share_world_motion(delta, x, tuning.world_share)
        share_world_motion(delta, xp, tuning.world_share)
        for point in (hood_p, hood_pp):
            _transform_point(delta, point, moved)
            for k in range(3):
                point[k] += tuning.hood_world_share * (moved[k] - point[k])
        root[:] = new_root
        # Gravity (along the rig's -up) and wind (M4, gusts a function of the step's time) in
        # the local frame.
        scale = gust_scale(t_sim, gust, tuning.gust_period)
        up = cloth.up
        for k in range(3):
            gravity_l[k] = -tuning.gravity * (root[0, k] * up[0] + root[1, k] * up[1]
                                              + root[2, k] * up[2])
            wind_l[k] = scale * (root[0, k] * wind[0] + root[1, k] * wind[1]
                                 + root[2, k] * wind[2])
        for i in range(nv):
            for k in range(3):
                acc[i, k] = gravity_l[k] + tuning.wind_scale[i] * wind_l[k]
        # M2 then M6: the upper jacket is solved, the pinned top row follows it.
        solve_layer(links, model.layer, last, out.layer_rot, out.layer_pos, out.layer_tips,
                    below)
        skinned_pose(links, cloth, below, top, now.ref)
        hold_pinned_row(top, cloth, below.shape[0] > 0, tuning.horizontal_limit)
        # M10 before M6: the colliders where this step ends, and the pinned row outside them.
        collider_poses(links, colliders, now)
        plane_poses(links, root, colliders, now)
        push_out_points(top, now.centers, now.axes, colliders.radii, now.cap_a, now.cap_b,
                        colliders.capsule_radii, now.plane_p, now.plane_n)
        # Substeps: as set, or in the automatic quality mode as few as keep the pinned row's
        # move per substep under the tolerance.
        substeps = tuning.max_substeps
        if tuning.quality_tolerance > 0.0 and substeps > 1:
            move = 0.0
            for c in range(cols):
                for k in range(3):
                    move = max(move, abs(top[c, k] - x[c, k]))
            substeps = int(min(substeps, max(1, np.ceil(move / tuning.quality_tolerance))))
        pin_from = x.copy() if substeps > 1 else x
        x[:cols] = top
        xp[:cols] = top
        if substeps != damp_for:
            e = tuning.design_exponent / substeps
            lost_per_each(tuning.damping, e, damp)
            contact_damp = lost_per(tuning.contact_damping, e)
            damp_for = substeps
        # Beyond the far distance the cloth rides on its pinned top row with its last shape
        # and no cloth step runs; a change blends the simulated and the riding cloth over the
        # steps instead of popping.
        if skin > 0.0:
            for i in range(cols, nv):
                for k in range(3):
                    ride[i, k] += top[i % cols, k]
        if skin >= 1.0:
            for i in range(cols, nv):
                for k in range(3):
                    xp[i, k] = x[i, k]
                    x[i, k] = ride[i, k]
            _copy_posed(now, before)
            state.started[0] = True
        else:
            _simulate(model, tuning, state, before, now, acc, damp, contact_damp, dt, substeps,
                      pin_from, stats)
            if skin > 0.0:
                for i in range(cols, nv):
                    for k in range(3):
                        x[i, k] += skin * (ride[i, k] - x[i, k])
        for k in range(3):
            hood_acc[k] = gravity_l[k] + tuning.hood_wind_scale * wind_l[k]
        hood_step(links, cloth, hood_p, hood_pp, hood_acc, dt, hood_damp)
    if motion.steps > 0 and not (np.isfinite(x).all() and np.isfinite(hood_p).all()):
        stats[NON_FINITE] = 1.0
    return t_sim


@njit(cache=True)
def _simulate(model, tuning, state, before, now, acc, damp, contact_damp, dt, substeps, pin_from,
              stats):
    """One cloth step (kernel.cloth_step, the colliders already posed in `now`) and its stats."""
    colliders, cloth = model.colliders, model.cloth
    if not state.started[0]:        # no step before: substeps start where this one ends
        _copy_posed(now, before)
    deepest, limited, sweeps = cloth_step(
        cloth, colliders, tuning, state,
        StepControl(acc, damp, contact_damp, dt, substeps, pin_from), now, before)
    # Where the next step's substeps start from: this step's end.
    _copy_posed(now, before)
    state.started[0] = True
    stats[DEEPEST] = max(stats[DEEPEST], deepest)
    stats[LIMITED] += limited
    stats[SWEEPS] += sweeps
    stats[SUBSTEPS] += substeps


@njit(cache=True)
def _copy_posed(src, dst):
    """Every array of one bundles.Posed into another's."""
    dst.centers[:] = src.centers
    dst.axes[:] = src.axes
    dst.cap_a[:] = src.cap_a
    dst.cap_b[:] = src.cap_b
    dst.plane_p[:] = src.plane_p
    dst.plane_n[:] = src.plane_n
    dst.ref[:] = src.ref


@njit(cache=True)
def gust_scale(t_ns, gust, period):
    """Return the wind's factor at a step's time.

    Two slow incommensurate gusts of relative size ``gust`` (1 without). A function of the
    stamp only, so a replay sees the live wind.
    """
    if gust == 0.0:
        return 1.0
    phase = 2 * np.pi * (t_ns * 1e-9) / period
    return 1.0 + gust * (0.6 * np.sin(phase) + 0.4 * np.sin(2.7 * phase + 1.3))
