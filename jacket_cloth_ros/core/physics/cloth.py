# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The cloth (numba): Verlet, constraints, M11, M12 against the body, strain limit; one step.

Compiled because at these sizes per-call overhead, not arithmetic, decides: a numpy port that
relaxes colour by colour is many times slower (`make bench-kernel`, docs/performance.md).

Order within a step, as in the article and the yardstick: Verlet (M4) with per-vertex damping
(M13, M15), Gauss-Seidel sweeps over both constraint groups (M5), tethers when chosen instead
of M12, ellipsoid push-out in ellipsoid space (M10) plus capsules and planes, maximum distance
(M11), and the top-down hard vertical pass (M12), which keeps the cloth outside the colliders;
then a strain limit on the horizontals and M12 once more.
"""

import numpy as np

from ..choices import Choice
from ..compiled import borrowed, njit
from .colliders import (
    body_parts, collide, posed_body, push_out, push_out_of, push_out_passes_of)

# Fused multiply-add, reciprocals and signless zeros only: no 'nnan'/'ninf', which would let
# LLVM drop the checks that keep a NaN from reaching /tf.
_FAST = {'contract', 'arcp', 'nsz'}


@njit(cache=True)
def integrate(x, xp, free, acc, damping, contact, contact_damping, dt):
    """M4 Verlet: x += (x - x_prev)(1 - damping) + a dt^2; M15: contact adds damping."""
    dt2 = dt * dt
    for i in range(x.shape[0]):
        if not free[i]:
            continue
        d = damping[i] + contact_damping if contact[i] else damping[i]
        if d > 1.0:
            d = 1.0
        for k in range(3):
            v = x[i, k] - xp[i, k]
            xp[i, k] = x[i, k]
            x[i, k] += v * (1.0 - d) + acc[i, k] * dt2


@njit(cache=True, fastmath=_FAST)
def relax(x, free, ca, cb, rest, stiffness, iterations, tolerance):
    """M5: Gauss-Seidel over distance constraints; each end moves by its share of the error.

    Near its rest length a constraint's correction 1 - rest/length is the series of
    1 - (1 + u)^(-1/2) in u = (length/rest)^2 - 1 to the third power, without a square root
    or a division (the square-root approximation of Jakobsen's "Advanced Character Physics",
    one order further); beyond about 12 % stretch or compression it is computed exactly.
    Stops early once a sweep moves no vertex more than ``tolerance`` (m; 0 never stops
    early), the automatic quality mode. Returns the sweeps run.
    """
    # Each end's share (stiffness over the number of free ends, 0 when pinned) and the rest
    # length's inverse square, once per call: the sweeps then run with no division at all.
    n = ca.shape[0]
    wa, wb, inv_rest2 = np.empty(n), np.empty(n), np.empty(n)
    for j in range(n):
        fa, fb = free[ca[j]], free[cb[j]]
        share = stiffness[j] * (0.5 if fa and fb else 1.0)
        wa[j] = share if fa else 0.0
        wb[j] = share if fb else 0.0
        rest2 = rest[j] * rest[j]
        inv_rest2[j] = 1.0 / rest2 if rest2 > 0.0 else 0.0        # not if it underflows
    for sweep in range(iterations):
        largest = 0.0
        for j in range(n):
            a, b = ca[j], cb[j]
            d0 = x[b, 0] - x[a, 0]
            d1 = x[b, 1] - x[a, 1]
            d2 = x[b, 2] - x[a, 2]
            length2 = d0 * d0 + d1 * d1 + d2 * d2
            u = length2 * inv_rest2[j] - 1.0
            if abs(u) < SERIES_REACH:
                f = u * (0.5 + u * (-0.375 + u * 0.3125))
            else:
                length = np.sqrt(length2)
                if length < 1e-9:
                    continue
                f = 1.0 - rest[j] / length
            fa, fb = f * wa[j], f * wb[j]
            x[a, 0] += d0 * fa
            x[a, 1] += d1 * fa
            x[a, 2] += d2 * fa
            x[b, 0] -= d0 * fb
            x[b, 1] -= d1 * fb
            x[b, 2] -= d2 * fb
            if tolerance > 0.0:
                largest = max(largest, abs(f) * np.sqrt(length2) * max(wa[j], wb[j]))
        if largest < tolerance:
            return sweep + 1
    return iterations


# Where relax uses its series: |u| under this, stretch within about -13 % .. +12 %; the
# first term left out (35/128 u^4) is then at most 1 % of the correction.
SERIES_REACH = 0.25


@njit(cache=True)
def relax_xpbd(x, free, ca, cb, rest, compliance, lam, dt, iterations, tolerance):
    """Relax the constraints with XPBD (Macklin et al. 2016); return the sweeps run.

    Compliance instead of stiffness, so the cloth's softness no longer depends on the
    iteration count or the step; ``lam`` accumulates each constraint's multiplier over the
    sweeps of one (sub)step. Unit masses.
    """
    lam[:] = 0.0
    inv_dt2 = 1.0 / (dt * dt) if dt > 0.0 else 0.0
    for sweep in range(iterations):
        largest = 0.0
        for j in range(ca.shape[0]):
            a, b = ca[j], cb[j]
            wa = 1.0 if free[a] else 0.0
            wb = 1.0 if free[b] else 0.0
            if wa + wb == 0.0:
                continue
            d0 = x[b, 0] - x[a, 0]
            d1 = x[b, 1] - x[a, 1]
            d2 = x[b, 2] - x[a, 2]
            length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if length < 1e-9:
                continue
            alpha = compliance[j] * inv_dt2
            dlam = (rest[j] - length - alpha * lam[j]) / (wa + wb + alpha)
            lam[j] += dlam
            f = -dlam / length
            x[a, 0] += wa * d0 * f
            x[a, 1] += wa * d1 * f
            x[a, 2] += wa * d2 * f
            x[b, 0] -= wb * d0 * f
            x[b, 1] -= wb * d1 * f
            x[b, 2] -= wb * d2 * f
            if tolerance > 0.0:
                largest = max(largest, abs(dlam))
        if largest < tolerance:
            return sweep + 1
    return iterations


# Projections of one vertical edge's lower vertex onto its rest length and out of the body,
# and the push-out (m) under which they have converged.
VERTICAL_COLLISION_ITERATIONS = 8
CONVERGED = 1e-7


@njit(cache=True)
def hard_vertical_pass_outside(x, upper, lower, rest, contact, body):
    """M12 that agrees with the colliders: each vertical at its length, outside the body.

    Top-down, each lower vertex at its rest length from the upper one and outside the body.
    Where the straight line runs into a collider, the edge turns about its upper vertex onto
    the collider's surface (projected alternately onto the length and out of the body), so the
    column wraps around a lifted thigh at its length instead of being pushed out stretched
    afterwards. Outside wins where both cannot hold. ``body``: the colliders as a bundles.Body.
    Returns the deepest push-out.
    """
    return _verticals_outside(x, upper, lower, rest, contact, 0, upper.shape[0], body)


@njit(cache=True)
def _verticals_outside(x, upper, lower, rest, contact, first, end, body):
    """hard_vertical_pass_outside over the vertical edges ``first`` to ``end`` - 1."""
    ellipsoids, capsules, planes = body_parts(body)
    deepest = 0.0
    for j in range(first, end):
        a, b = upper[j], lower[j]
        for _ in range(VERTICAL_COLLISION_ITERATIONS):
            d0 = x[a, 0] - x[b, 0]
            d1 = x[a, 1] - x[b, 1]
            d2 = x[a, 2] - x[b, 2]
            length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if length > 1e-9:
                f = (length - rest[j]) / length
                x[b, 0] += d0 * f
                x[b, 1] += d1 * f
                x[b, 2] += d2 * f
            depth = push_out_of(x, b, ellipsoids, capsules, planes)
            if depth < CONVERGED:       # outside (-1), or on the surface at its length
                break
            contact[b] = True           # M15: it touched the body during this step
            deepest = max(deepest, depth)
        else:       # not converged, as in the crease of two colliders: outside wins
            _, depth = push_out_passes_of(x, b, CONVERGED, ellipsoids, capsules, planes)
            if depth >= CONVERGED:
                _outside_towards(x, a, b, body)
    return deepest


# Halvings of the edge when its lower vertex is stuck inside: its length to 1e-6 of itself.
OUTSIDE_BISECTIONS = 20


@njit(cache=True)
def _outside_towards(x, a, b, body):
    """Put b at the point of the edge a-b farthest from a that is outside, if a is outside.

    The last resort where the push-out alternates between two colliders (the middle of a
    crease): the edge gets shorter, which M12 allows, and the vertex ends outside.
    """
    b0, b1, b2 = x[b, 0], x[b, 1], x[b, 2]
    d = np.array((b0 - x[a, 0], b1 - x[a, 1], b2 - x[a, 2]))
    if not _outside_at(x, a, b, 0.0, d, body):
        x[b, 0], x[b, 1], x[b, 2] = b0, b1, b2      # a is inside too: nothing to walk to
        return
    out, inside = 0.0, 1.0
    for _ in range(OUTSIDE_BISECTIONS):
        t = 0.5 * (out + inside)
        if _outside_at(x, a, b, t, d, body):
            out = t
        else:
            inside = t
    _place_on_edge(x, a, b, out, d)


@njit(cache=True, inline='always')
def _place_on_edge(x, a, b, t, d):
    """Put vertex b at x[a] + t d."""
    x[b, 0], x[b, 1], x[b, 2] = x[a, 0] + t * d[0], x[a, 1] + t * d[1], x[a, 2] + t * d[2]


@njit(cache=True, inline='always')
def _outside_at(x, a, b, t, d, body):
    """Put b at x[a] + t d; True if it is outside there (a push-out under CONVERGED)."""
    _place_on_edge(x, a, b, t, d)
    return push_out(x, b, body) < CONVERGED


@njit(cache=True)
def hard_pass_with_strain_limit(x, free, cloth, limit, contact, body):
    """M12 outside the body, row by row, each row's horizontals held to (1 + ``limit``) rest.

    Top-down: a row's verticals at their length from the row above and outside the body
    (hard_vertical_pass_outside), then its horizontals shortened (limit_stretch) and its
    verticals put back, a few rounds, before the next row hangs from it. Nothing else limits
    the horizontals once the push-out and M12 have moved their ends (docs/accuracy.md), and a
    row settled before the next keeps the work to the rows that need it. ``body``: the
    colliders as a bundles.Body.
    """
    upper, lower, rest = cloth.vert_a, cloth.vert_b, cloth.vert_rest
    ha, hb, hrest = cloth.horiz_a, cloth.horiz_b, cloth.horiz_rest
    cols = cloth.pin_local.shape[0]
    nv, nh = upper.shape[0], ha.shape[0]
    j, h = 0, 0
    while j < nv:
        row = lower[j] // cols
        end = j
        while end < nv and lower[end] // cols == row:
            end += 1
        _verticals_outside(x, upper, lower, rest, contact, j, end, body)
        while h < nh and ha[h] // cols < row:
            h += 1
        h_end = h
        while h_end < nh and ha[h_end] // cols == row:
            h_end += 1
        for _ in range(STRAIN_LIMIT_ROUNDS):
            if not limit_stretch(x, free, ha[h:h_end], hb[h:h_end], hrest[h:h_end], limit,
                                 STRAIN_LIMIT_SWEEPS):
                break
            _verticals_outside(x, upper, lower, rest, contact, j, end, body)
        j, h = end, h_end


# Sweeps of the horizontal strain limit: two bring a row's excess from one edge to its
# neighbours and back. Rounds of the limit and the verticals, until the row holds: a row that
# wraps a thigh raised sideways converges slowly (docs/motion_capture.md), and a row that
# holds after one round ends there, so the bound costs only where it is needed.
STRAIN_LIMIT_SWEEPS = 2
STRAIN_LIMIT_ROUNDS = 40


@njit(cache=True)
def hold_pinned_row(top, cloth, has_pads, limit):
    """M6 with the strain limit: the pinned row's own edges held to (1 + ``limit``) rest.

    The M2 pads (``has_pads``) spread the skinned row as the arms swing and the rows below
    hang from it; no pads, or a negative limit (off), leave the row as skinned.
    """
    if not has_pads or limit < 0.0:
        return
    a = cloth.row_a
    ends = np.ones(top.shape[0], dtype=np.bool_)       # every vertex of the row may move
    limit_stretch(top, ends, a, a + 1, cloth.row_rest, limit, STRAIN_LIMIT_SWEEPS)


@njit(cache=True)
def limit_stretch(x, free, ea, eb, rest, limit, sweeps):
    """Provot's strain limit: shorten each edge over (1 + ``limit``) rest, moving free ends.

    Only shortens, never lengthens, so folds and compression are left to the solve. Both
    ends move half the excess when both are free. Returns the shortenings made.
    """
    shortened = 0
    for _ in range(sweeps):
        for j in range(ea.shape[0]):
            a, b = ea[j], eb[j]
            d0 = x[b, 0] - x[a, 0]
            d1 = x[b, 1] - x[a, 1]
            d2 = x[b, 2] - x[a, 2]
            length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            most = (1.0 + limit) * rest[j]
            if length <= most:
                continue
            shortened += 1
            f = (length - most) / length
            fa = 0.5 * f if free[b] else f
            fb = 0.5 * f if free[a] else f
            if free[a]:
                x[a, 0] += d0 * fa
                x[a, 1] += d1 * fa
                x[a, 2] += d2 * fa
            if free[b]:
                x[b, 0] -= d0 * fb
                x[b, 1] -= d1 * fb
                x[b, 2] -= d2 * fb
    return shortened


@njit(cache=True)
def _pull_within(x, i, c0, c1, c2, reach):
    """Move vertex i along its line to (c0, c1, c2) until it is ``reach`` away; True if moved."""
    d0 = x[i, 0] - c0
    d1 = x[i, 1] - c1
    d2 = x[i, 2] - c2
    length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    if length <= reach:
        return False
    g = reach / length
    x[i, 0] = c0 + d0 * g
    x[i, 1] = c1 + d1 * g
    x[i, 2] = c2 + d2 * g
    return True


@njit(cache=True)
def limit_distance(x, free, ref, max_distance):
    """M11: move a vertex back towards its reference point when it is too far. Returns count."""
    moved = 0
    for i in range(x.shape[0]):
        if free[i] and _pull_within(x, i, ref[i, 0], ref[i, 1], ref[i, 2], max_distance[i]):
            moved += 1
    return moved


@njit(cache=True)
def tethers(x, free, anchor, length):
    """Long-range attachments: no vertex further from its pinned anchor than its tether.

    The alternative to M12 that NvCloth and Chaos Cloth use: unilateral, so the cloth may
    bunch up but never stretch beyond the tether. Returns the number of vertices pulled back.
    """
    moved = 0
    for i in range(x.shape[0]):
        a = anchor[i]
        if free[i] and _pull_within(x, i, x[a, 0], x[a, 1], x[a, 2], length[i]):
            moved += 1
    return moved


class StretchLimit(Choice):
    """How the vertical stretch left by the iterative solve is removed (stretch_limit)."""

    NONE = 0
    HARD_PASS = 1       # M12
    TETHERS = 2         # long-range attachments


class Solver(Choice):
    """The constraint solver (solver): the article's relaxation, or XPBD."""

    GAUSS_SEIDEL = 0
    XPBD = 1


# The compiled code compares plain integers.
LIMIT_NONE, LIMIT_HARD_PASS, LIMIT_TETHERS = (int(m) for m in StretchLimit)
SOLVER_GAUSS_SEIDEL, SOLVER_XPBD = (int(m) for m in Solver)


@njit(cache=True)
def _lerp(out, a, b, w):
    """Set out = a + w (b - a), elementwise over arrays of one shape."""
    fa, fb, fo = a.reshape(-1), b.reshape(-1), out.reshape(-1)
    for i in range(fo.shape[0]):
        fo[i] = fa[i] + w * (fb[i] - fa[i])


@njit(cache=True)
def _orthonormalise(axes):
    """Gram-Schmidt on each 3x3 frame's columns (interpolated rotations drift off unit)."""
    for e in range(axes.shape[0]):
        for c in range(3):
            for p in range(c):
                dot = axes[e, 0, c] * axes[e, 0, p] + axes[e, 1, c] * axes[e, 1, p] \
                    + axes[e, 2, c] * axes[e, 2, p]
                for r in range(3):
                    axes[e, r, c] -= dot * axes[e, r, p]
            norm = np.sqrt(axes[e, 0, c] ** 2 + axes[e, 1, c] ** 2 + axes[e, 2, c] ** 2)
            for r in range(3):
                axes[e, r, c] /= norm


@njit(cache=True)
def _normalise_rows(normals):
    """Each row to unit length (interpolated plane normals)."""
    for k in range(normals.shape[0]):
        norm = np.sqrt(normals[k, 0] ** 2 + normals[k, 1] ** 2 + normals[k, 2] ** 2)
        for r in range(3):
            normals[k, r] /= norm


@njit(cache=True)
def cloth_step(cloth, colliders, tuning, state, control, now, before):
    """Advance the jacket cloth one fixed step in ``control.substeps`` equal substeps.

    Substeps as in "Small Steps". Takes core.bundles: ClothModel, ColliderModel, Tuning,
    ClothState, StepControl, and Posed twice.

    ``control.damping`` and ``contact_damping`` are per substep. The pinned vertices, the
    colliders and the M11 references are given where they are at the end of the step
    (``now``); with substeps they move there in equal parts from where they were at its
    start (``control.pin_from``, ``before``). Colliders that jumped ahead a whole step would
    push cloth out at the substep's speed, many times the body's (the depenetration pop of
    Small Steps).
    Returns (deepest push-out, vertices limited by M11, relaxation sweeps run).
    """
    # Its caller holds every array for the call: no reference counted on them within.
    cloth, colliders, tuning, state, control, now, before = borrowed(
        (cloth, colliders, tuning, state, control, now, before))
    x, xp, contact, lam = state.x, state.xp, state.contact, state.lam
    free, ca, cb, rest = cloth.free, cloth.con_a, cloth.con_b, cloth.con_rest
    upper, lower, vrest = cloth.vert_a, cloth.vert_b, cloth.vert_rest
    anchor, tether = cloth.tether_anchor, cloth.tether_length
    ha, hb, hrest = cloth.horiz_a, cloth.horiz_b, cloth.horiz_rest
    limit_horizontal = tuning.horizontal_limit >= 0.0
    stiffness, iterations, compliance = tuning.stiffness, tuning.iterations, tuning.compliance
    max_distance, limit_mode, solver = tuning.max_distance, tuning.limit_mode, tuning.solver
    tolerance = tuning.sweep_tolerance
    acc, damping, contact_damping = control.acc, control.damping, control.contact_damping
    dt, substeps, pin_from = control.dt, control.substeps, control.pin_from
    centers, axes, cap_a, cap_b = now.centers, now.axes, now.cap_a, now.cap_b
    plane_p, plane_n, ref = now.plane_p, now.plane_n, now.ref
    centers0, axes0, cap_a0, cap_b0 = before.centers, before.axes, before.cap_a, before.cap_b
    plane_p0, plane_n0, ref0 = before.plane_p, before.plane_n, before.ref
    deepest = 0.0
    limited = 0
    sweeps = 0
    h = dt / substeps
    if substeps > 1:
        pin_to = x.copy()
        c_to, a_to, ka_to, kb_to = centers.copy(), axes.copy(), cap_a.copy(), cap_b.copy()
        pp_to, pn_to, ref_to = plane_p.copy(), plane_n.copy(), ref.copy()
    for s in range(substeps):
        if substeps > 1:
            w = (s + 1.0) / substeps
            for i in range(x.shape[0]):
                if not free[i]:
                    for k in range(3):
                        x[i, k] = pin_from[i, k] + w * (pin_to[i, k] - pin_from[i, k])
                        xp[i, k] = x[i, k]
            _lerp(centers, centers0, c_to, w)
            _lerp(axes, axes0, a_to, w)
            _orthonormalise(axes)
            _lerp(cap_a, cap_a0, ka_to, w)
            _lerp(cap_b, cap_b0, kb_to, w)
            _lerp(plane_p, plane_p0, pp_to, w)
            _lerp(plane_n, plane_n0, pn_to, w)
            _normalise_rows(plane_n)
            _lerp(ref, ref0, ref_to, w)
        body = posed_body(colliders, now)       # once the substep has moved them
        integrate(x, xp, free, acc, damping, contact, contact_damping, h)
        if solver == SOLVER_XPBD:
            sweeps += relax_xpbd(x, free, ca, cb, rest, compliance, lam, h, iterations,
                                 tolerance)
        else:
            sweeps += relax(x, free, ca, cb, rest, stiffness, iterations, tolerance)
        if limit_mode == LIMIT_TETHERS:
            tethers(x, free, anchor, tether)
        deepest = max(deepest, collide(x, free, body, contact))
        if limit_horizontal and limit_mode != LIMIT_HARD_PASS:
            # Without M12 the horizontals' limit runs before M11, which then has the last word.
            limit_stretch(x, free, ha, hb, hrest, tuning.horizontal_limit, STRAIN_LIMIT_SWEEPS)
        limited += limit_distance(x, free, ref, max_distance)
        if limit_mode == LIMIT_HARD_PASS:
            # M12 run last, as the article does, but agreeing with the colliders: a plain
            # pass pulled cloth into the body and the push-out after it stretched the column
            # again (docs/method.md).
            # Its push-outs measure the pass (the straight line it starts from), not the cloth:
            # they stay out of the deepest push-out reported.
            if limit_horizontal:
                hard_pass_with_strain_limit(x, free, cloth, tuning.horizontal_limit, contact,
                                            body)
            else:
                hard_vertical_pass_outside(x, upper, lower, vrest, contact, body)
    if substeps > 1:        # leave the frames exactly where the step ends (lerp rounds)
        centers[:], axes[:], cap_a[:], cap_b[:] = c_to, a_to, ka_to, kb_to
        plane_p[:], plane_n[:], ref[:] = pp_to, pn_to, ref_to
    return deepest, limited, sweeps
