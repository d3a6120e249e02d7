# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A character's steps and bones in one compiled call: alone, or every character of a crowd.

Each character runs advance_slot on its own bundles (core.bundles.CrowdSlot), alone
(JacketSimulation.process, its warm-up) as in a crowd, so its results are the same to the bit;
for a crowd numba's prange spreads the characters over the threads numba.set_num_threads
allows. One call instead of one per character: the Python between calls, not the steps, was
most of a small character's cost.
"""

from numba import prange
from numba.typed import List

from ..bundles import Motion
from ..compiled import borrowed, njit
from .pose import kept_bone_poses
from .sampling import FILLED, fill_sample, root_jump
from .step import advance

# What advance_slot returns, and step_steady for an input it leaves to Python.
STEPS_FAILED, BONES_FINITE, BONES_NOT_FINITE, NOT_STEADY = range(4)


@njit(cache=True)
def load_motion(motion, clock, stats, a, b, timing):
    """Write one input's two samples and step clock into a slot's motion arrays, zero its stats.

    ``motion``: the slot's (q_a, q_b, quat_a, quat_b, pos_a, pos_b); ``a``, ``b``: the two
    bundles.JointSample; ``timing``: (stamp_a, span, t_sim, dt_ns, steps), into ``clock``.
    In one call: as numpy copies, one per array, they were the largest Python share of a
    crowd's character (docs/crowd.md).
    """
    q_a, q_b, quat_a, quat_b, pos_a, pos_b = motion
    q_a[:] = a.q
    q_b[:] = b.q
    quat_a[:] = a.quat
    quat_b[:] = b.quat
    for k in range(3):
        pos_a[k] = a.root[k, 3]
        pos_b[k] = b.root[k, 3]
    for k in range(5):
        clock[k] = timing[k]
    stats[:] = 0.0


@njit(cache=True, nogil=True)
def advance_slot(slot):
    """Run one character's prepared steps (its StepJob's motion, loaded by load_motion).

    Then the bones' poses into ``slot.bones``, as JacketSimulation.bones computes them.
    Returns STEPS_FAILED if the steps stopped on a division by zero (the caller resets that
    character, as JacketSimulation.process does), else whether the bones are finite; the step
    clock's t_sim moves on to the last step.
    """
    slot = borrowed(slot)           # its caller holds every array for the call
    c = slot.clock
    motion = Motion(slot.q_a, slot.q_b, slot.quat_a, slot.quat_b, slot.pos_a, slot.pos_b,
                    c[0], c[1], c[2], c[3], c[4])
    try:
        c[2] = advance(slot.model, slot.tuning, slot.state, slot.before, motion, slot.out,
                       slot.work)
    except Exception:  # noqa: BLE001 - numba names no exception object; only division raises
        return STEPS_FAILED
    out, state = slot.out, slot.state
    finite = kept_bone_poses(state.x, state.hood_p, out.links, slot.model.cloth, slot.bone_rc,
                             slot.layer_parents, out.layer_rot, out.layer_pos, slot.bones)
    return BONES_FINITE if finite else BONES_NOT_FINITE


@njit(cache=True, parallel=True)
def advance_crowd(slots, active, ran):
    """advance_slot for ``slots[active[j]]`` into ``ran[j]``, characters spread over threads."""
    for j in prange(active.shape[0]):
        ran[j] = advance_slot(slots[active[j]])


@njit(cache=True)
def prepare_steady(intakes, active, stamps, positions, starts, taken):
    """steady_input for ``intakes[active[j]]`` with ``positions[starts[j]:starts[j + 1]]``.

    Into ``taken[j]``: whether the input is loaded; one call for every steady input of a batch.
    """
    for j in range(active.shape[0]):
        taken[j] = steady_input(intakes[active[j]], stamps[j],
                                positions[starts[j]:starts[j + 1]])


@njit(cache=True)
def steady_input(intake, stamp, positions):
    """Load an armed character's input as JacketSimulation.prepare and load_motion would.

    Only an input they would step without a word: a stamp after the last within reset_gap,
    finite positions and quaternion, no teleport or fast turn, 1 to max_steps_per_input steps.
    Anything else returns False with the slot and the last sample as they were (only the
    intake's scratch sample written), and the input goes the Python way.
    """
    clock, limits, slot_clock = intake.clock, intake.limits, intake.slot_clock
    # Armed only on a plan without warnings: every name of the list is in it.
    plan, last, new = intake.plan, intake.last, intake.new
    if positions.shape[0] != plan.joint_from.shape[0] + plan.world_from.shape[0]:
        return False
    gap = (stamp - clock[0]) * 1e-9                     # JacketSimulation._check_stamp
    if not gap > 0.0 or gap > limits[0]:
        return False
    if fill_sample(positions, plan, last, new) != FILLED:
        return False
    move, turn = root_jump(last.root, new.root, last.quat, new.quat)
    if move > limits[1] or turn > limits[2]:            # JacketSimulation._jump
        return False
    t_sim, dt_ns = slot_clock[2], clock[1]
    steps = (stamp - t_sim) // dt_ns
    if steps <= 0 or steps > clock[2]:
        return False
    load_motion(intake.motion, slot_clock, intake.stats, last, new,
                (clock[0], stamp - clock[0], t_sim, dt_ns, steps))
    last.q[:] = new.q
    last.root[:] = new.root
    last.quat[:] = new.quat
    clock[0] = stamp
    return True


@njit(cache=True)
def step_steady(intake, slot, stamp, positions):
    """steady_input, then advance_slot if it took the input; NOT_STEADY if it did not.

    A character alone: one call from its JointState's content to its bones.
    """
    if not steady_input(intake, stamp, positions):
        return NOT_STEADY
    return advance_slot(slot)


# numba's typed.List, used from Python, compiles its append and item assignment for each item
# type at first use and never caches them: most of a crowd node's start (docs/crowd.md).
# Built and written here instead, where numba's cache keeps them. Their items are borrowed:
# taking one out (a crowd's character each round, a lone character's lane each input) counted
# an atomic reference on each of its hundred-odd arrays, in and out.
@njit(cache=True)
def borrowed_list(item):
    """Return a typed list holding ``item`` borrowed; the caller keeps ``item`` while it does."""
    items = List()
    items.append(borrowed(item))
    return items


@njit(cache=True)
def put_borrowed(items, index, item):
    """Set ``items[index]`` to ``item`` borrowed, or append it at ``index == len(items)``.

    The caller keeps ``item`` while the list holds it.
    """
    if index == len(items):
        items.append(borrowed(item))
    else:
        items[index] = borrowed(item)
