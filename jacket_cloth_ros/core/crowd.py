# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Many simulations stepped together: one compiled call per round of inputs, in parallel.

Each simulation prepares its input in Python as it does alone (JacketSimulation.prepare);
the steps of all of them then run in crowd_steps.advance_crowd, spread over numba's threads;
each takes its steps back (JacketSimulation.complete). Same inputs, same bits as alone.

A character whose last input went that way without a warning or reset is armed: its next
inputs are checked and loaded for all such characters in one compiled call
(crowd_steps.prepare_steady), which takes only what prepare would step without a word and
leaves anything else (a new name list, a stamp gap, a teleport, a NaN, a viewer, ...) to
prepare. The Python per input was most of a crowd character's cost (docs/crowd.md).
"""

import operator
import os
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from .bundles import CrowdSlot, JointSample, StepOutput, ints, steady_intake
from .compiled import FixedTypes
from .inputs import Sample
from .physics import crowd as crowd_steps
from .simulation import Bones, StageTimer, StepJob, StepReport

# GNU OpenMP's threads (numba's omp layer) spin between calls by default, taking a core from
# the executor thread and the machine's other processes; read when the pool first starts.
os.environ.setdefault('OMP_WAIT_POLICY', 'PASSIVE')

if TYPE_CHECKING:           # for the annotations only
    from .simulation import JacketSimulation


def threads_for(wanted: int) -> int:
    """Return how many threads a crowd uses.

    :param wanted: the threads asked for; 0: one per core numba sees.
    """
    most = numba.config.NUMBA_NUM_THREADS
    return most if wanted <= 0 else min(int(wanted), most)


def threading_layer() -> str:
    """Return numba's threading layer once a parallel kernel ran (omp, tbb or workqueue).

    Every one of them is safe here: the crowd's kernel is only ever called from one thread
    (the node's executor, or the replay's loop), and the node never forks.
    """
    try:
        return numba.threading_layer()
    except ValueError:              # no parallel kernel ran yet
        return 'not started'


class CrowdSteps:
    """The compiled steps of many simulations, run together.

    :param threads: how many threads the call spreads over (0: all cores, as NUMBA_NUM_THREADS).
    """

    def __init__(self, threads: int = 0):
        self.threads = threads_for(threads)
        self.sims = []
        self._slots = None          # a typed list of each simulation's CrowdSlot, once one
        self._mine = []             # the same slots, read from Python (the typed list boxes)
        self._intakes = None                # each slot's SteadyIntake (a typed list)
        self._my_intakes = []               # the same, read from Python
        # Writes into the typed lists (crowd_steps.put), rare: each checks the item's type,
        # as numba's typed.List did, so that an item of another type is refused, not misread.
        self._put_slot = FixedTypes(crowd_steps.put, check=True)
        self._put_intake = FixedTypes(crowd_steps.put, check=True)
        self._keys = []
        self._call = None
        self._load = FixedTypes(crowd_steps.load_motion)
        self._steady = FixedTypes(crowd_steps.prepare_steady)
        self._armed = []            # per simulation: what its intake was armed with, or None
        self.calls = 0              # compiled calls made (one per round of inputs)
        self.steady_inputs = 0      # inputs the compiled intake took

    def add(self, sim: 'JacketSimulation') -> int:
        """Add a simulation; returns its index.

        :param sim: a simulation, stepped with the others from now on.
        """
        index = len(self.sims)
        self.sims.append(sim)
        slot, key = self._slot(sim)
        self._keys.append(key)
        self._armed.append(None)
        self._set_slot(index, slot)
        self._set_intake(index, steady_intake(slot))
        if self._call is None:      # typed once: every slot has the same types
            self._call = FixedTypes(crowd_steps.advance_crowd)
            # Both loaded now, not on the first inputs: that stalled the first batch by
            # seconds and the first steady input by more than a step.
            none = np.zeros(0, dtype=np.int64)
            self._call(self._slots, none, none)
            self._steady(self._intakes, none, none, np.zeros(0), np.zeros(1, dtype=np.int64),
                         np.zeros(0, dtype=np.bool_))
            self._set_slot(index, slot)         # crowd_steps.put loaded now too
            self._set_intake(index, self._my_intakes[index])
        return index

    def time_stages(self, timer: StageTimer) -> None:
        """Run every round's compiled call through a profiler's ``timer`` from now on.

        The stage ``step`` (physics.crowd.advance_crowd, all the round's simulations) is
        replaced by what ``timer('step', call)`` returns; a crowd never given a timer makes
        the call directly, as before.

        :param timer: called with the stage's name and callable; returns the callable to run
            in its place.
        :raises ValueError: before the second simulation, which loads the call.
        """
        if self._call is None:
            raise ValueError('a crowd of fewer than two simulations has no compiled call')
        self._call = timer('step', self._call)

    @staticmethod
    def _key(sim):
        return (sim.tuning,)            # the state is held once: only a new tuning is new

    def _slot(self, sim):
        """Make a slot on the simulation's own arrays, with motion and output arrays of its own."""
        state = sim.state
        q = len(sim.skeleton.joint_names)
        out = sim.step_output()
        layer = sim.rig.layer
        parents = ints(layer.parent_index if layer else [])
        slot = CrowdSlot(sim.model, sim.tuning, state, sim._before, np.zeros(q), np.zeros(q),
                         np.zeros(4), np.zeros(4), np.zeros(3), np.zeros(3),
                         np.zeros(5, dtype=np.int64), out, ints(sim.bone_set.grid), parents,
                         _identity_poses(len(sim.bone_names)))
        return slot, self._key(sim)

    def _current(self, index):
        """Return the slot of simulation ``index``, made again if its tuning changed.

        A live parameter change makes a new Tuning; the state is held once, never replaced.
        """
        sim = self.sims[index]
        key = self._key(sim)
        if not all(map(operator.is_, key, self._keys[index])):
            slot, key = self._slot(sim)
            self._set_slot(index, slot)
            self._keys[index] = key
            self._set_intake(index, steady_intake(slot))
            self._armed[index] = None
        return self._mine[index]

    def _set_slot(self, index, slot):
        """Set (or append, for a new simulation) simulation ``index``'s slot."""
        self._slots = _put(self._slots, self._mine, self._put_slot, index, slot)

    def _set_intake(self, index, intake):
        """Set (or append, for a new simulation) simulation ``index``'s intake."""
        self._intakes = _put(self._intakes, self._my_intakes, self._put_intake, index, intake)

    def prepare_steady(self, inputs: Sequence[tuple]) -> tuple[list, list]:
        """Check and load the inputs of armed simulations in one compiled call.

        :param inputs: (k, simulation index, stamp ns, names, positions), at most one per
            simulation.
        :returns: (taken, rest): taken as (k, index, StepReport, StepJob), what
            JacketSimulation.prepare would have returned, their motion already in the slot (for
            :meth:`run`'s ``loaded``); the rest, in the same form as given, for prepare.
        """
        armed, sims, mine = self._armed, self.sims, self._mine
        fast, rest = [], []
        for item in inputs:
            index = item[1]
            sim, arm = sims[index], armed[index]
            # Armed for this very name list, tuning and last sample (a simulation stepped
            # outside the crowd, or reset, has another), no viewer, an int stamp, the slot on
            # this tuning.
            if (arm is not None and arm[0] is item[3] and arm[1] is sim.tuning
                    and arm[2] is sim.parser.world_joint and arm[3] is sim.last
                    and sim.lod.viewer is None and type(item[2]) is int
                    and mine[index].tuning is sim.tuning):
                fast.append(item)
            else:
                armed[index] = None         # prepare moves its last sample on
                rest.append(item)
        if not fast:
            return [], rest
        starts = np.zeros(len(fast) + 1, dtype=np.int64)
        np.cumsum([len(item[4]) for item in fast], out=starts[1:])
        taken = np.zeros(len(fast), dtype=np.bool_)
        self._steady(self._intakes, np.array([item[1] for item in fast], dtype=np.int64),
                     np.array([item[2] for item in fast], dtype=np.int64),
                     np.concatenate([item[4] for item in fast], dtype=np.float64), starts, taken)
        out = []
        for item, ok in zip(fast, taken.tolist()):
            if ok:
                out.append((item[0], item[1], *self._steady_job(item[1], item[2])))
            else:
                armed[item[1]] = None
                rest.append(item)
        self.steady_inputs += len(out)
        return out, rest

    def _steady_job(self, index, stamp):
        """Return the report and job prepare would have made of an input steady_input loaded."""
        sim, slot = self.sims[index], self._mine[index]
        sim.ready_bones = None
        sample = Sample(stamp, slot.q_b.copy(), self._my_intakes[index].last.root.copy(),
                        slot.quat_b.copy(), [])
        sim.parser.last = JointSample(sample.q, sample.root, sample.root_quat)
        clock = slot.clock
        return StepReport(stamp), StepJob(sample, int(clock[4]), sim.last, int(clock[2]),
                                          sim.dt_ns, sim.tuning)

    def settle(self, index: int, names: Sequence[str], report: StepReport) -> None:
        """After an input's steps: arm simulation ``index`` if its next input may be steady.

        It may if prepare would take it on from here as steady_input does: this input was
        stepped without a warning, reset or skipped step, at full detail with no viewer, and
        its name list is a tuple (a list could change under the same object).

        :param index: the simulation's index in the crowd.
        :param names: the input's joint name list.
        :param report: the input's step report.
        """
        sim = self.sims[index]
        if (not isinstance(names, tuple) or not report.accepted or report.reset
                or report.steps <= 0 or report.skipped_steps or report.warnings
                or sim.lod.viewer is not None or sim.lod.level or sim.lod.skin
                or self._mine[index].tuning is not sim.tuning):
            self._armed[index] = None
            return
        arm = self._armed[index]
        if arm is not None:             # steady_input moved its intake on itself
            self._armed[index] = arm[:3] + (sim.last,)
            return
        (plan, _), last, p = sim.parser.plan(names), sim.last, sim.params
        self._set_intake(index, steady_intake(
            self._mine[index], plan, (last.q, last.root, last.root_quat),
            (last.stamp_ns, sim.dt_ns, p.max_steps_per_input),
            (p.reset_gap, sim.teleport_m, p.teleport_angle_deg)))
        self._armed[index] = (names, sim.tuning, sim.parser.world_joint, last)

    def run(self, jobs: Sequence[tuple[int, 'StepJob']],
            loaded: frozenset = frozenset()) -> list[tuple[StepOutput, int]]:
        """Run each (simulation index, prepared job) in one call; returns (output, status) each.

        The status is crowd_steps's (STEPS_FAILED, BONES_FINITE, BONES_NOT_FINITE). Each
        output is that simulation's own arrays, written again by its next job:
        JacketSimulation.complete takes them at once.

        :param jobs: (simulation index, job from prepare), at most one job per simulation.
        :param loaded: the simulations whose job :meth:`prepare_steady` loaded.
        """
        if not jobs:
            return []
        active = np.empty(len(jobs), dtype=np.int64)
        for j, (index, job) in enumerate(jobs):
            if index in loaded:
                active[j] = index
                continue
            slot = self._current(index)
            if slot.tuning is not job.tuning:      # the level of detail's tuning, this input
                slot = slot._replace(tuning=job.tuning)
                self._set_slot(index, slot)
            a, b = job.start, job.sample
            self._load((slot.q_a, slot.q_b, slot.quat_a, slot.quat_b, slot.pos_a, slot.pos_b),
                       slot.clock, slot.out.stats, JointSample(a.q, a.root, a.root_quat),
                       JointSample(b.q, b.root, b.root_quat),
                       (a.stamp_ns, b.stamp_ns - a.stamp_ns, job.t_sim, job.dt_ns, job.steps))
            active[j] = index
        ran = np.zeros(len(jobs), dtype=np.int64)
        numba.set_num_threads(self.threads)
        # Characters handed out one at a time: a thread that the host slows takes fewer.
        numba.set_parallel_chunksize(1)
        self._call(self._slots, active, ran)
        self.calls += 1
        out = []
        for j, (index, _) in enumerate(jobs):
            slot = self._mine[index]
            self.sims[index].t_sim = int(slot.clock[2])
            out.append((slot.out, int(ran[j])))
        return out

    def bones(self, index: int, finite: bool) -> Bones:
        """Return simulation ``index``'s bones as the last call left them (a copy).

        :param index: the simulation's index in the crowd.
        :param finite: whether the call found the bones finite (its status), kept in the Bones.
        """
        sim = self.sims[index]
        return Bones(sim.bone_names, sim.bone_parents, self._mine[index].bones.copy(), finite)


def _put(items, mine, put, index, item):
    """Set ``item`` at ``index`` of a typed list and of its Python mirror (or append it).

    Returns the typed list, made by crowd_steps.listed for the first item (``items`` None).
    """
    if items is None:
        items = crowd_steps.listed(item)
    else:
        put(items, index, item)
    if index == len(mine):
        mine.append(item)
    else:
        mine[index] = item
    return items


def stepped(steps: CrowdSteps,
            inputs: Sequence[tuple[int, int, Sequence[str], np.ndarray]],
            after_round: Callable[[list[int], list, bool], None] | None = None) -> list:
    """Process inputs as rounds of one call.

    A round takes at most one input per simulation, in their order.

    :param steps: the crowd's compiled steps, every simulation of the inputs added.
    :param inputs: (simulation index, stamp ns, names, positions) each.
    :param after_round: called after each round with its inputs' indices, the reports and
        whether it was the last; it may take the outputs of its inputs (a simulation with
        another input in a later round is stepped on then, and its state is no longer this
        input's).
    :returns: each input's StepReport, in the inputs' order; ``step_cost_ns`` is its round's
        wall time.
    """
    sims = steps.sims
    reports = [None] * len(inputs)
    pending = list(range(len(inputs)))
    while pending:
        seen, this, later = set(), [], []
        for k in pending:
            (later if inputs[k][0] in seen else this).append(k)
            seen.add(inputs[k][0])
        started = time.perf_counter_ns()
        taken, rest = steps.prepare_steady([(k, *inputs[k]) for k in this])
        jobs = []
        for k, index, report, job in taken:
            reports[k] = report
            jobs.append((k, index, job))
        loaded = frozenset(index for _, index, _ in jobs)
        for k, index, stamp, names, positions in rest:
            reports[k], job = sims[index].prepare(stamp, names, positions)
            if job is not None:
                jobs.append((k, index, job))
            elif reports[k].accepted:       # a reset, or no step due: its bones as they are
                sims[index].check_bones(reports[k])
        results = steps.run([(index, job) for _, index, job in jobs], loaded)
        for (k, index, job), (out, status) in zip(jobs, results):
            sim = sims[index]
            sim.complete(reports[k], job, out, status != crowd_steps.STEPS_FAILED)
            if not reports[k].reset:        # the bones the call made are the state's
                sim.ready_bones = steps.bones(index, status == crowd_steps.BONES_FINITE)
            sim.check_bones(reports[k])     # before settle: a reset is never steady
            steps.settle(index, inputs[k][2], reports[k])
        cost = time.perf_counter_ns() - started
        for k in this:
            reports[k].step_cost_ns = cost
        pending = later
        if after_round is not None:
            after_round(this, reports, not later)
    return reports


def _identity_poses(n):
    """Return ``n`` bone poses at the origin with no rotation.

    A grid bone whose edges all lie flat keeps the rotation its slot holds (pose.grid_bones):
    a unit quaternion before any other.
    """
    poses = np.zeros((n, 7))
    poses[:, 6] = 1.0
    return poses
