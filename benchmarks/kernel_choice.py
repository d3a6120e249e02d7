# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Why the cloth step is a numba kernel: the same step in numpy, timed against it.

    make bench-kernel            (or: python benchmarks/kernel_choice.py [--steps N])

Feeds the shipped rig through the showcase clip and, at every step, runs one cloth step three
ways on the same state: the numba kernel (what ships), a numpy port that relaxes the
constraints colour by colour (no two constraints of a colour share a vertex, so each colour is
one vectorised update), and, when ../shared/limit/cloth_ref.c exists, the C yardstick's own
figure. Prints the median cost of each per step, their ratios, and how far the numpy port's
result lies from the kernel's (the colour order is not the kernel's Gauss-Seidel order).
"""

import argparse
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from jacket_cloth_ros.core.bundles import copied  # noqa: E402
from jacket_cloth_ros.core.compiled import FixedTypes  # noqa: E402
from jacket_cloth_ros.core.physics.cloth import cloth_step  # noqa: E402
from jacket_cloth_ros.core.fabric import load_fabric  # noqa: E402
from jacket_cloth_ros.core.rig import load_rig  # noqa: E402
from jacket_cloth_ros.core.skeleton import load_shipped_character  # noqa: E402
from jacket_cloth_lab.speed import Yardstick, captured_steps, limit_source  # noqa: E402


def colours(ca, cb, n):
    """Greedy colouring of constraints, in Gauss-Seidel order: index arrays per colour."""
    used = [set() for _ in range(n)]
    colour_of = []
    for a, b in zip(ca, cb):
        c = 0
        while c in used[a] or c in used[b]:
            c += 1
        used[a].add(c)
        used[b].add(c)
        colour_of.append(c)
    colour_of = np.array(colour_of)
    return [np.nonzero(colour_of == c)[0] for c in range(colour_of.max() + 1)]


def numpy_step(x, xp, free, acc, damping, contact, contact_damping, dt, ca, cb, rest, stiffness,
               iterations, groups, centers, axes, radii, ref, max_distance, rows_of_vertical):
    """Run the kernel's step (Verlet, relax, ellipsoids, M11, M12) in vectorised numpy.

    Ellipsoids only: the shipped rig's floor plane is never reached in the showcase clip.
    """
    f = free[:, None]
    d = np.minimum(1.0, damping + np.where(contact, contact_damping, 0.0))[:, None]
    v = x - xp
    xp[:] = np.where(f, x, xp)
    x[:] = np.where(f, x + v * (1 - d) + acc * dt * dt, x)
    wa, wb = free[ca].astype(float), free[cb].astype(float)
    share = 1.0 / np.maximum(wa + wb, 1.0)
    for _ in range(iterations):
        for g in groups:                         # about 10 numpy calls per colour
            a, b = ca[g], cb[g]
            delta = x[b] - x[a]
            length = np.linalg.norm(delta, axis=1)
            k = stiffness[g] * (length - rest[g]) / np.maximum(length, 1e-9) * share[g]
            x[a] += (wa[g] * k)[:, None] * delta
            x[b] -= (wb[g] * k)[:, None] * delta
    contact[:] = False
    for e in range(len(centers)):
        q = ((x - centers[e]) @ axes[e]) / radii[e]
        r2 = (q * q).sum(axis=1)
        hit = free & (r2 < 1.0) & (r2 > 1e-12)
        surface = (q[hit] / np.sqrt(r2[hit])[:, None]) * radii[e]
        x[hit] = surface @ axes[e].T + centers[e]
        contact |= hit
    off = x - ref
    dist = np.linalg.norm(off, axis=1)
    far = free & (dist > max_distance)
    x[far] = ref[far] + off[far] * (max_distance[far] / dist[far])[:, None]
    for upper, lower, vrest in rows_of_vertical:
        delta = x[upper] - x[lower]
        length = np.linalg.norm(delta, axis=1)
        x[lower] += delta * ((length - vrest) / np.maximum(length, 1e-9))[:, None]


def run(steps):
    skeleton = load_shipped_character()
    rig = load_rig(skeleton)
    groups = colours(rig.con_a, rig.con_b, rig.n)
    C = rig.cols
    rows_of_vertical = [(rig.vert_a[r * C:(r + 1) * C], rig.vert_b[r * C:(r + 1) * C],
                         rig.vert_rest[r * C:(r + 1) * C]) for r in range(rig.rows - 1)]
    # Every step's kernel inputs as the simulation made them (120 Hz steps, 60 Hz inputs).
    captured = captured_steps(skeleton, rig, load_fabric('tweed_jacket'), 'showcase',
                              steps / 120.0 + 0.1)[:steps]
    real_step = FixedTypes(cloth_step, check=False)  # typed once, as the simulation
    numba_ns, numpy_ns, diff = [], [], []
    for args in captured:
        a = copied(args)
        t0 = time.perf_counter_ns()
        real_step(*a)
        numba_ns.append(time.perf_counter_ns() - t0)
        cloth, colliders, tuning, state, control, now, _ = copied(args)
        x = state.x
        t0 = time.perf_counter_ns()
        numpy_step(x, state.xp, cloth.free, control.acc, control.damping, state.contact,
                   control.contact_damping, control.dt, cloth.con_a, cloth.con_b,
                   cloth.con_rest, tuning.stiffness, tuning.iterations, groups, now.centers,
                   now.axes, colliders.radii, now.ref, tuning.max_distance, rows_of_vertical)
        numpy_ns.append(time.perf_counter_ns() - t0)
        diff.append(np.abs(x - a[3].x).max())
    return rig, len(groups), np.median(numba_ns), np.median(numpy_ns), np.array(diff)


def limit_ns(rig):
    """Return the C yardstick's median step for the same grid, or None if it is not here."""
    source = limit_source()
    if source is None:
        return None
    return float(Yardstick(source).step_ns(rig.cols, rig.rows, 8, 21000)['step_ns_median'])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--steps', type=int, default=600, help='steps of the showcase clip')
    args = parser.parse_args()
    rig, n_colours, numba_med, numpy_med, diff = run(args.steps)
    print(f'grid {rig.cols}x{rig.rows}, {len(rig.con_a)} constraints in {n_colours} colours, '
          f'{len(rig.colliders)} ellipsoids, {args.steps} steps of the showcase clip')
    print(f'numba kernel : median {numba_med / 1e3:8.1f} us/step')
    print(f'numpy colours: median {numpy_med / 1e3:8.1f} us/step  = {numpy_med / numba_med:5.1f}x '
          f'the kernel')
    print(f'numpy vs kernel after one step: max |dx| median {np.median(diff) * 1e3:.3f} mm, '
          f'worst {diff.max() * 1e3:.3f} mm (colour order differs from Gauss-Seidel order)')
    ref = limit_ns(rig)
    if ref is None:
        print('C yardstick: ../shared/limit/cloth_ref.c not here; no limit ratio')
    else:
        print(f'C yardstick  : median {ref / 1e3:8.1f} us/step; kernel = {numba_med / ref:.2f}x, '
              f'numpy = {numpy_med / ref:.1f}x the limit')


if __name__ == '__main__':
    main()
