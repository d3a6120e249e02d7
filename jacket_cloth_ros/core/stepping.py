# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A character's compiled steps: one call from an input's content to its bones, alone or in crowds.

Every way a simulation steps (its own inputs, its warm-up, a crowd's round) runs the same
compiled call, physics.crowd.advance_slot, on the character's one CrowdSlot: its state arrays,
its motion arrays and its bones, typed once. After an input that went the whole way without a
warning or reset the character is armed: its next input, if it is one JacketSimulation.prepare
would step without a word, is checked and loaded by compiled code too (physics.crowd
.steady_input; step_steady alone), so a steady input runs no Python between its content and
its bones. Anything else (a new name list, a stamp gap, a teleport, a NaN, a viewer, ...)
goes through prepare.
"""

from dataclasses import dataclass

import numpy as np

from .bundles import CrowdSlot, JointSample, NamePlan, Tuning, steady_intake
from .compiled import FixedTypes
from .inputs import Sample
from .physics import crowd as slot_steps

STEPS_FAILED, BONES_FINITE, NOT_STEADY = (slot_steps.STEPS_FAILED, slot_steps.BONES_FINITE,
                                          slot_steps.NOT_STEADY)


@dataclass(slots=True)
class StepJob:
    """One input's compiled steps, prepared (JacketSimulation.prepare) and not yet run."""

    sample: Sample             # the input they run to
    steps: int
    start: Sample              # the input they run from (the last one)
    t_sim: int                 # ns of the last step run before them
    dt_ns: int
    tuning: Tuning             # the simulation's, or its level of detail's (core/lod.py)


class Stepper:
    """A character's CrowdSlot, its steady intake and the compiled calls that run them.

    :param slot: the character's slot, on its simulation's state and tuning (held once).
    """

    def __init__(self, slot: CrowdSlot):
        self.slot = slot
        self.intake = steady_intake(slot)
        # What the intake was armed for (names, tuning, world_joint, last sample), or None.
        self.armed = None
        self.positions = np.zeros(0)
        # The positions buffer as bytes: a caller that reads them straight from a message
        # (ros/steady_lane.py) copies them in without the alignment a float view needs.
        self.positions_bytes = self.positions.view(np.uint8)
        self._lend_lane()
        self._tuned = slot          # the slot on the level of detail's tuning, while it lasts
        self._load = FixedTypes(slot_steps.load_motion)
        self.advance = FixedTypes(slot_steps.advance_slot)
        self.steady = FixedTypes(slot_steps.step_steady)
        self.steady_inputs = 0      # inputs the compiled intake took

    def retune(self, tuning: Tuning) -> None:
        """Take a new tuning (a live parameter change); disarm.

        :param tuning: the simulation's new tuning.
        """
        self.slot = self._tuned = self.slot._replace(tuning=tuning)
        self.armed = None

    def ready_for(self, key: tuple, stamp_ns: object) -> bool:
        """Tell whether an input may go the compiled way; if not, disarm.

        :param key: (names, tuning, world_joint, last sample) the input comes on: armed for
            these very objects (a simulation stepped another way, or reset, has others), but
            for names an equal tuple will do (a tuple cannot change under the intake).
        :param stamp_ns: the input's stamp: an int.
        """
        if self.armed_for(key) and type(stamp_ns) is int:
            return True
        self.armed = None
        return False

    def armed_for(self, key: tuple) -> bool:
        """Tell whether the intake is armed for ``key`` (:meth:`ready_for`), disarming nothing.

        :param key: (names, tuning, world_joint, last sample) an input comes on.
        """
        arm = self.armed
        return (arm is not None and arm[1] is key[1] and arm[2] is key[2] and arm[3] is key[3]
                and (arm[0] is key[0] or (type(key[0]) is tuple and arm[0] == key[0])))

    def load_steady(self) -> None:
        """Load the steady call now: the unarmed intake takes nothing and moves nothing."""
        self.steady(self.intake, self.slot, 0, self.positions)

    def take(self, key: tuple, stamp_ns: int, positions: object) -> int:
        """Step an input the compiled way if it is steady; its status, or NOT_STEADY.

        :param key: what the input comes on (:meth:`ready_for`).
        :param stamp_ns: the input's stamp, ns.
        :param positions: its positions, one per name.
        :returns: physics.crowd's status (STEPS_FAILED, BONES_FINITE, BONES_NOT_FINITE), or
            NOT_STEADY with nothing moved: the input goes through prepare.
        """
        if not self.ready_for(key, stamp_ns):
            return NOT_STEADY
        buffer = self.positions
        try:        # copied: the kernel was typed for a writable C float64 array
            if len(positions) != buffer.shape[0]:       # no broadcasting one value to all
                raise ValueError('another length')
            buffer[:] = positions
        except (ValueError, TypeError):         # another length or not numbers: prepare says
            self.armed = None
            return NOT_STEADY
        status = self.steady(self.intake, self.slot, stamp_ns, buffer)
        if status == NOT_STEADY:
            self.armed = None
        return status

    def taken(self, stamp_ns: int) -> Sample:
        """Return the sample of an input the intake loaded, as prepare would have parsed it.

        :param stamp_ns: the input's stamp, ns.
        """
        slot = self.slot
        self.steady_inputs += 1
        return Sample(stamp_ns, slot.q_b.copy(), self.intake.last.root.copy(),
                      slot.quat_b.copy(), [])

    def load(self, job: StepJob) -> CrowdSlot:
        """Write a prepared job's motion into the slot; return the slot tuned for the job.

        :param job: from JacketSimulation.prepare.
        """
        slot = self.slot
        if slot.tuning is not job.tuning:       # the level of detail's tuning, this input
            if self._tuned.tuning is not job.tuning:
                self._tuned = slot._replace(tuning=job.tuning)
            slot = self._tuned
        a, b = job.start, job.sample
        self._load((slot.q_a, slot.q_b, slot.quat_a, slot.quat_b, slot.pos_a, slot.pos_b),
                   slot.clock, slot.out.stats, JointSample(a.q, a.root, a.root_quat),
                   JointSample(b.q, b.root, b.root_quat),
                   (int(a.stamp_ns), int(b.stamp_ns - a.stamp_ns), int(job.t_sim),
                    int(job.dt_ns), int(job.steps)))
        return slot

    def run(self, job: StepJob) -> int:
        """Run a prepared job's steps and bones; physics.crowd's status.

        :param job: from JacketSimulation.prepare.
        """
        return self.advance(self.load(job))

    def rearm(self, key: tuple) -> bool:
        """After an input the intake took: armed on for ``key``; False if it did not take it.

        :param key: what the next input must come on (:meth:`ready_for`).
        """
        if self.armed is None:
            return False
        self.armed = key            # steady_input moved its intake on itself
        return True

    def arm(self, key: tuple, plan: NamePlan, last: Sample, clock: tuple,
            limits: tuple) -> None:
        """Arm the intake for the next input (the last one went the whole way without a word).

        :param key: what the next input must come on (:meth:`ready_for`).
        :param plan: where each value of the name list goes (InputParser's).
        :param last: the last sample.
        :param clock: dt_ns and max_steps_per_input.
        :param limits: reset_gap (s), teleport distance (m) and teleport_angle_deg.
        """
        self.intake = steady_intake(self.slot, plan, (last.q, last.root, last.root_quat),
                                    (last.stamp_ns, *clock), limits)
        self.positions = np.zeros(len(key[0]))
        self.positions_bytes = self.positions.view(np.uint8)
        self._lend_lane()
        self.armed = key

    def _lend_lane(self) -> None:
        """Put the steady lane's arrays in a typed list of one: ``lane`` (ros/steady_lane.py).

        (positions, their bytes, intake, slot): numba unboxes a typed list as one pointer,
        where the bundles passed as they are cost a conversion of each of their arrays on
        every call, several times the lane's own reading and laying out. Made anew when the
        intake is armed: an unarmed intake takes no input, whatever slot it holds. The list
        holds them borrowed (physics.crowd.borrowed_list), so it is never read from Python;
        ``_lent`` keeps them while ``lane`` is this list.
        """
        lent = (self.positions, self.positions_bytes, self.intake, self.slot)
        self.lane = slot_steps.borrowed_list(lent)
        self._lent = lent


def identity_poses(n: int) -> np.ndarray:
    """Return ``n`` bone poses at the origin with no rotation.

    A grid bone whose edges all lie flat keeps the rotation its slot holds (pose.grid_bones):
    a unit quaternion before any other.

    :param n: how many bones.
    """
    poses = np.zeros((n, 7))
    poses[:, 6] = 1.0
    return poses
