# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Where a steady input's compiled call goes beyond its cloth steps: the method's parts, hot.

    python benchmarks/step_parts.py [--rounds 7] [--calls 2000]

`bench speed`'s profile sets the step stage against the kernel-only limit (the bare cloth
step times the steps of an input); this says what the rest of that stage is. On the shipped
character after 5 s of the walk, each part of one input's call (physics.crowd.advance_slot:
two 120 Hz steps, then the bones) is called many times in a compiled loop on the state the
walk left, so no Python and no unboxing is timed: the whole call (its state put back before
each), the bare cloth step on the states `bench speed` captures, and each of the method's
stages around the cloth step that the package names publicly. Prints each part's median over
the rounds in us and as a share of the bare cloth step; "not placed" is the whole less the
parts (the step's own bookkeeping: its scratch, copies, the hem's path, the retry check).
"""

import argparse
import os
import statistics
import sys
import time

import numpy as np
from numba import njit

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from jacket_cloth_ros.core.bundles import Posed  # noqa: E402
from jacket_cloth_ros.core.fabric import load_fabric  # noqa: E402
from jacket_cloth_ros.core.physics.cloth import hold_pinned_row  # noqa: E402
from jacket_cloth_ros.core.physics.colliders import (  # noqa: E402
    collider_poses, plane_poses, posed_body, push_out_points)
from jacket_cloth_ros.core.physics.crowd import advance_slot  # noqa: E402
from jacket_cloth_ros.core.physics.hood import hood_step  # noqa: E402
from jacket_cloth_ros.core.physics.pose import (  # noqa: E402
    forward_kinematics, kept_bone_poses, share_world_motion, skinned_pose, solve_layer)
from jacket_cloth_ros.core.physics.step import copy_posed  # noqa: E402
from jacket_cloth_ros.core.rig import load_rig  # noqa: E402
from jacket_cloth_ros.core.simulation import JacketSimulation  # noqa: E402
from jacket_cloth_ros.core.skeleton import load_shipped_character  # noqa: E402
from jacket_cloth_lab.accuracy import clip_inputs  # noqa: E402
from jacket_cloth_lab.speed import captured_steps, kernel_step_ns  # noqa: E402

# The parts in the order a step runs them; "per input" ones run once an input, the rest once
# a step.
PARTS = ('forward kinematics (M7)', 'world share of the cloth, x and xp (M14)',
         'upper-jacket layer, partial (M1/M2)', 'upper-jacket layer, in full at the last step',
         'skinned top row and references (M6, M11)', 'top row held (M6 strain limit)',
         'colliders posed (M10)', 'top row pushed out of the body (M6, M10)', 'hood (M8)',
         'bones (M9, per input)')
PER_INPUT = {'upper-jacket layer, in full at the last step', 'bones (M9, per input)'}


@njit
def _put_back(slot, kept, was):
    """Put the slot's state, clock and last colliders back as ``kept`` and ``was`` hold them."""
    state = slot.state
    state.x[:] = kept[0]
    state.xp[:] = kept[1]
    state.hood_p[:] = kept[2][0]
    state.hood_pp[:] = kept[2][1]
    state.root[:] = kept[3]
    state.contact[:] = kept[4]
    slot.clock[:] = kept[5]
    copy_posed(was, slot.before)


@njit
def _whole(slot, kept, was, calls, step):
    """advance_slot ``calls`` times (``step`` False: only the putting back), each from ``kept``."""
    for _ in range(calls):
        _put_back(slot, kept, was)
        if step:
            advance_slot(slot)


@njit
def _part(slot, which, posed, scratch, calls):
    """One of PARTS ``calls`` times on the slot's last pose, into scratch arrays."""
    model, state, out, tuning = slot.model, slot.state, slot.out, slot.tuning
    links, cloth, colliders = out.links, model.cloth, model.colliders
    world, top, ref, x, hood = scratch
    rot, pos, tips, below = (out.layer_rot.copy(), out.layer_pos.copy(), out.layer_tips.copy(),
                             out.below.copy())
    twist = out.sleeve_twist.copy()
    bones = slot.bones.copy()
    delta = np.eye(4)
    for _ in range(calls):
        if which == 0:
            forward_kinematics(model.skeleton, slot.q_b, world)
        elif which == 1:
            share_world_motion(delta, x, tuning.world_share)
            share_world_motion(delta, x, tuning.world_share)
        elif which == 2:
            solve_layer(links, model.layer, False, rot, pos, tips, below, twist)
        elif which == 3:
            solve_layer(links, model.layer, True, rot, pos, tips, below, twist)
        elif which == 4:
            skinned_pose(links, cloth, below, top, ref)
        elif which == 5:
            hold_pinned_row(top, cloth, below.shape[0] > 0, tuning.horizontal_limit)
        elif which == 6:
            collider_poses(links, colliders, posed)
            plane_poses(links, state.root, colliders, posed)
        elif which == 7:
            push_out_points(top, posed_body(colliders, posed))
        elif which == 8:
            hood_step(links, cloth, hood[0], hood[1], hood[2], 1.0 / 120.0, 0.1,
                      posed.plane_p, posed.plane_n)
        else:
            kept_bone_poses(state.x, state.hood_p, links, cloth, slot.bone_rc,
                            slot.layer_parents, out.layer_rot, out.layer_pos, bones)


def _timed(run, calls):
    """Return the us per call of ``run(calls)``, once compiled."""
    run(3)
    started = time.perf_counter_ns()
    run(calls)
    return (time.perf_counter_ns() - started) / calls / 1e3


def main(argv=None):
    """Time the parts and print them."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rounds', type=int, default=7)
    parser.add_argument('--calls', type=int, default=2000)
    args = parser.parse_args(argv)
    skeleton = load_shipped_character()
    rig, fabric = load_rig(skeleton), load_fabric('tweed_jacket')
    sim = JacketSimulation(skeleton, rig, fabric)
    for stamp, names, positions in clip_inputs(skeleton, 'walk', 5.0):
        sim.process(stamp, names, positions)
    slot = sim.steps.slot
    steps = int(slot.clock[4])
    state = slot.state
    kept = (state.x.copy(), state.xp.copy(), np.stack([state.hood_p, state.hood_pp]),
            state.root.copy(), state.contact.copy(), slot.clock.copy())
    was = Posed(*(a.copy() for a in slot.before))
    posed = Posed(*(a.copy() for a in slot.before))
    scratch = (slot.out.links.copy(), state.x[:rig.cols].copy(), state.x.copy(), state.x.copy(),
               np.stack([state.hood_p, state.hood_pp, np.zeros(3)]))
    captured = captured_steps(skeleton, rig, fabric)
    rounds = {name: [] for name in ('whole', 'cloth step') + PARTS}
    for _ in range(args.rounds):
        rounds['whole'].append(_timed(lambda n: _whole(slot, kept, was, n, True), args.calls)
                               - _timed(lambda n: _whole(slot, kept, was, n, False), args.calls))
        rounds['cloth step'].append(kernel_step_ns(captured, repeat=3) / 1e3)
        for k, name in enumerate(PARTS):
            rounds[name].append(_timed(lambda n: _part(slot, k, posed, scratch, n), args.calls))
    median = {name: statistics.median(v) for name, v in rounds.items()}
    cloth = median['cloth step']
    print(f'One steady input of the walk, {steps} steps, median of {args.rounds} rounds '
          f'(us; x the bare cloth step):')

    def row(name, us, note=''):
        print(f'  {name:46s}{us:7.1f}  {us / cloth:5.2f}x{note}')
    row('whole call (steps and bones)', median['whole'])
    row(f'cloth steps, {steps} x the bare step', steps * cloth)
    placed = 0.0
    for name in PARTS:
        times = 1 if name in PER_INPUT else steps
        if name == 'upper-jacket layer, partial (M1/M2)':
            times = steps - 1
        placed += times * median[name]
        row(name, times * median[name], f'  ({times} x {median[name]:.2f})')
    row('not placed', median['whole'] - steps * cloth - placed)
    return 0


if __name__ == '__main__':
    sys.exit(main())
