# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""All fixed steps of one input in one compiled call (numba): JacketSimulation.process.

Why one call: with each part compiled on its own, the Python between them still cost several
times the cloth step, and a live node that sleeps between inputs pays it again with cold
caches (docs/performance.md). Each step runs these stages:

  ``_pose_skeleton`` (M7 interpolation, forward kinematics) -> ``_follow_world`` (M14 world
  share) -> ``_forces`` (gravity, wind) -> ``_pin_top_row`` (M1/M2 layer, M6 pinned row and
  M11 references, colliders posed (M10) with the pinned row outside them) -> the cloth
  (``cloth.cloth_step`` in ``_substeps_for`` substeps, run again in twice as many when it
  overstretched a row, or riding its top row far from the viewer) -> M8 hood.
"""

import numpy as np

from ..bundles import StepControl
from ..compiled import njit
from .cloth import LIMIT_HARD_PASS, cloth_step, hold_pinned_row
from .colliders import collider_poses, plane_poses, posed_body, push_out_points
from .hood import hood_step
from .pose import (
    _transform_point, forward_kinematics, quat_matrix, quat_slerp, relative_move,
    share_world_motion, skinned_pose, solve_layer)

# The ``stats`` slots; HEM_PATH: the hem's mean move summed step by step (a cloth that keeps
# moving on a still body, measures.RestlessWatch); RETRIED: steps run again in finer substeps.
DEEPEST, LIMITED, SWEEPS, SUBSTEPS, NON_FINITE, HEM_PATH, RETRIED = range(7)
STAT_SLOTS = RETRIED + 1

# With M12, a step that starts with every horizontal edge within this many times the fabric's
# strain limit over its rest length and ends with one beyond is run again from its start in
# twice the substeps.
RETRY_OVER_LIMIT = 2.0


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
def advance(model, tuning, state, before, motion, out, work):
    """Run ``motion.steps`` fixed steps from sample a towards sample b.

    Takes core.bundles: Model, Tuning, ClothState, Posed, Motion, StepOutput, StepScratch.
    ``state`` is moved in place; ``before`` holds the colliders and references where the
    last step ended and is moved on to this one's end; ``out.links`` and the layer arrays
    end with the last step's pose (the layer solved in full at that step only, following
    ``out.sleeve_twist``).
    ``out.stats`` accumulates the report's figures. Returns the time of the last step (ns).
    """
    cloth = model.cloth
    x, xp, hood_p = state.x, state.xp, state.hood_p
    cols = cloth.pin_local.shape[0]
    nv = x.shape[0]
    damp_for = 0
    contact_damp = 0.0
    hood_damp = lost_per(tuning.hood_damping, tuning.design_exponent)
    # Only M12 holds the rows; a stretch carried in from earlier steps no retry undoes.
    retry_over = RETRY_OVER_LIMIT * tuning.horizontal_limit \
        if tuning.limit_mode == LIMIT_HARD_PASS else -1.0
    dt_ns = motion.dt_ns
    dt = dt_ns * 1e-9
    t_sim = motion.t_sim
    # Each array of a bundle a compiled function is handed costs it a reference count in and
    # out, used or not (a call, atomic unless borrowed): the small helpers get what they use.
    skeleton, colliders, links = model.skeleton, model.colliders, out.links
    ha, hb, hr = cloth.horiz_a, cloth.horiz_b, cloth.horiz_rest
    (q, quat, new_root, delta, moved, gravity, wind, acc, hood_acc, top, now, damp, ride, x0,
     xp0, contact0, hem_before) = work
    for step in range(motion.steps):
        t_sim += dt_ns
        hem_before[:] = x[nv - cols:]
        _pose_skeleton(skeleton, motion, t_sim, q, quat, new_root, links)
        # Level of detail: the share of the riding cloth (core/lod.py) and, riding, each
        # vertex's offset from its column's top before the world share moves it.
        skin = tuning.skin_from + (tuning.skin_to - tuning.skin_from) * (step + 1.0) \
            / motion.steps
        if skin > 0.0:
            for i in range(cols, nv):
                for k in range(3):
                    ride[i, k] = x[i, k] - x[i % cols, k]
        _follow_world(tuning.world_share, tuning.hood_world_share, state, new_root,
                      delta, moved)
        _forces(cloth.up, tuning, state.root, t_sim, gravity, wind, acc,
                hood_acc)
        _pin_top_row(model, tuning.horizontal_limit, state.root, step == motion.steps - 1,
                     top, now, out)
        substeps = _substeps_for(tuning.max_substeps, tuning.quality_tolerance, top, x, cols)
        x0[:] = x          # where the pinned row starts from, and a retry's start
        xp0[:] = xp
        contact0[:] = state.contact
        x[:cols] = top
        xp[:cols] = top
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
            copy_posed(now, before)
            state.started[0] = True
        else:
            if substeps != damp_for:
                damp_for, contact_damp = _damping_for(tuning, substeps, damp)
            deepest, limited = out.stats[DEEPEST], out.stats[LIMITED]
            _simulate(cloth, colliders, tuning, state, before, now,
                      StepControl(acc, damp, contact_damp, dt, substeps, x0),
                      out.stats)
            if retry_over >= 0.0 and _overstretched(x, ha, hb, hr, retry_over) \
                    and not _overstretched(x0, ha, hb, hr, retry_over):
                # Faster than its substeps resolve (a thigh swept through a row): again from
                # the step's start in finer ones, rather than a stretch no later step undoes.
                # The pass thrown away counts in the cost (sweeps, substeps), not the figures.
                _restart(state, work)
                out.stats[DEEPEST], out.stats[LIMITED] = deepest, limited
                damp_for, contact_damp = _damping_for(tuning, 2 * substeps, damp)
                _simulate(cloth, colliders, tuning, state, before, now,
                          StepControl(acc, damp, contact_damp, dt, 2 * substeps,
                                      x0), out.stats)
                out.stats[RETRIED] += 1
            # Where the next step's substeps start from: this step's end.
            copy_posed(now, before)
            state.started[0] = True
            if skin > 0.0:
                for i in range(cols, nv):
                    for k in range(3):
                        x[i, k] += skin * (ride[i, k] - x[i, k])
        hood_step(links, cloth, hood_p, state.hood_pp, hood_acc, dt, hood_damp,
                  now.plane_p, now.plane_n)
        out.stats[HEM_PATH] += _mean_move(x[nv - cols:], hem_before)
    if motion.steps > 0 and not (np.isfinite(x).all() and np.isfinite(hood_p).all()):
        out.stats[NON_FINITE] = 1.0
    return t_sim


@njit(cache=True)
def _damping_for(tuning, substeps, damp):
    """Fill ``damp`` with the damping per substep of ``substeps``.

    Returns (the substeps it holds now, the contact damping per substep). The caller calls it
    only when the substeps change.
    """
    e = tuning.design_exponent / substeps
    lost_per_each(tuning.damping, e, damp)
    return substeps, lost_per(tuning.contact_damping, e)


@njit(cache=True)
def _overstretched(x, ha, hb, rest, most):
    """Tell whether a horizontal edge (``ha``-``hb``) is over (1 + ``most``) times ``rest``.

    A negative ``most`` (the strain limit off) never is.
    """
    if most < 0.0:
        return False
    for j in range(ha.shape[0]):
        a, b = ha[j], hb[j]
        bound = (1.0 + most) * rest[j]
        if ((x[a, 0] - x[b, 0]) ** 2 + (x[a, 1] - x[b, 1]) ** 2
                + (x[a, 2] - x[b, 2]) ** 2) > bound * bound:
            return True
    return False


@njit(cache=True)
def _restart(state, work):
    """Put the cloth back where the step started, its pinned row posed."""
    cols = work.top.shape[0]
    state.x[:] = work.x0
    state.xp[:] = work.xp0
    state.contact[:] = work.contact0
    state.x[:cols] = work.top
    state.xp[:cols] = work.top


@njit(cache=True)
def _mean_move(now, before):
    """Return the mean distance between two (K,3) sets of points."""
    total = 0.0
    for i in range(now.shape[0]):
        total += np.sqrt((now[i, 0] - before[i, 0]) ** 2 + (now[i, 1] - before[i, 1]) ** 2
                         + (now[i, 2] - before[i, 2]) ** 2)
    return total / max(now.shape[0], 1)


@njit(cache=True)
def _pose_skeleton(skeleton, motion, t_sim, q, quat, new_root, links):
    """M7: the skeleton between the two samples at the step's time, and its links' poses.

    Into ``q``, ``quat`` and ``new_root`` (the step's StepScratch) and ``links``.
    """
    w = min(1.0, max(0.0, (t_sim - motion.stamp_a) / motion.span))
    for k in range(q.shape[0]):
        q[k] = motion.q_a[k] + w * (motion.q_b[k] - motion.q_a[k])
    quat_slerp(motion.quat_a, motion.quat_b, w, quat)
    quat_matrix(quat, new_root)
    for k in range(3):
        new_root[k, 3] = motion.pos_a[k] + w * (motion.pos_b[k] - motion.pos_a[k])
    forward_kinematics(skeleton, q, links)


@njit(cache=True)
def _follow_world(world_share, hood_world_share, state, new_root, delta, moved):
    """M14: the cloth and hood feel only their share of the root's move through the world.

    The character moved by ``delta`` (old local -> new local, from ``state.root`` to
    ``new_root``); a world-space cloth would stay behind by that much.
    """
    root = state.root
    relative_move(new_root, root, delta)
    share_world_motion(delta, state.x, world_share)
    share_world_motion(delta, state.xp, world_share)
    for point in (state.hood_p, state.hood_pp):
        _transform_point(delta, point, moved)
        for k in range(3):
            point[k] += hood_world_share * (moved[k] - point[k])
    root[:] = new_root


@njit(cache=True)
def _forces(up, tuning, root, t_sim, gravity, wind_l, acc, hood_acc):
    """M4: gravity along the rig's -``up`` and wind (gusts by the step's time), local frame.

    Into the step's StepScratch ``gravity``, ``wind_l`` (the wind), ``acc`` and ``hood_acc``.
    """
    wind = tuning.wind
    scale = gust_scale(t_sim, tuning.gust, tuning.gust_period)
    for k in range(3):
        gravity[k] = -tuning.gravity * (root[0, k] * up[0] + root[1, k] * up[1]
                                        + root[2, k] * up[2])
        wind_l[k] = scale * (root[0, k] * wind[0] + root[1, k] * wind[1]
                             + root[2, k] * wind[2])
    for i in range(acc.shape[0]):
        for k in range(3):
            acc[i, k] = gravity[k] + tuning.wind_scale[i] * wind_l[k]
    for k in range(3):
        hood_acc[k] = gravity[k] + tuning.hood_wind_scale * wind_l[k]


@njit(cache=True)
def _pin_top_row(model, horizontal_limit, root, last, top, now, out):
    """M2 then M6, M11 and M10: where the pinned row, the references and the colliders are.

    The upper jacket is solved (in full at the ``last`` step), the pinned top row follows
    it into ``top``, then the colliders are posed where this step ends (``now``) and the
    pinned row is put outside them.
    """
    links, cloth, colliders = out.links, model.cloth, model.colliders
    solve_layer(links, model.layer, last, out.layer_rot, out.layer_pos, out.layer_tips,
                out.below, out.sleeve_twist)
    skinned_pose(links, cloth, out.below, top, now.ref)
    hold_pinned_row(top, cloth, out.below.shape[0] > 0, horizontal_limit)
    collider_poses(links, colliders, now)
    plane_poses(links, root, colliders, now)
    push_out_points(top, posed_body(colliders, now))


@njit(cache=True)
def _substeps_for(max_substeps, tolerance, top, x, cols):
    """Return the step's substeps: ``max_substeps``, or fewer in the automatic quality mode.

    There (a ``tolerance`` above 0), as few as keep the pinned row's move per substep under
    it.
    """
    substeps = max_substeps
    if tolerance > 0.0 and substeps > 1:
        move = 0.0
        for c in range(cols):
            for k in range(3):
                move = max(move, abs(top[c, k] - x[c, k]))
        substeps = int(min(substeps, max(1, np.ceil(move / tolerance))))
    return substeps


@njit(cache=True)
def _simulate(cloth, colliders, tuning, state, before, now, control, stats):
    """One cloth step (cloth.cloth_step, the colliders already posed in ``now``), its stats.

    ``before`` is left where the step started (the caller moves it on), so a retry starts
    from the same place.
    """
    if not state.started[0]:        # no step before: substeps start where this one ends
        copy_posed(now, before)
    deepest, limited, sweeps = cloth_step(cloth, colliders, tuning, state, control, now,
                                          before)
    stats[DEEPEST] = max(stats[DEEPEST], deepest)
    stats[LIMITED] += limited
    stats[SWEEPS] += sweeps
    stats[SUBSTEPS] += control.substeps


@njit(cache=True)
def copy_posed(src, dst):
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
