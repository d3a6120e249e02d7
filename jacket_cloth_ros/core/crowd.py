# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Many simulations stepped together: one compiled call per round of inputs, in parallel.

Each simulation's steps and bones run in the compiled call it runs alone (core/stepping.py,
physics.crowd.advance_slot), here all of a round's in crowd_steps.advance_crowd, spread over
numba's threads; each takes its steps back (JacketSimulation.finish). Same inputs, same bits
as alone.

The inputs of armed characters (core/stepping.py: the last input went the whole way without
a warning or reset) are checked and loaded for all of them in one compiled call
(crowd_steps.prepare_steady), which takes only what prepare would step without a word; the
rest go through JacketSimulation.prepare. The Python per input was most of a crowd
character's cost (docs/crowd.md).
"""

import os
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from .compiled import FixedTypes
from .physics import crowd as crowd_steps
from .simulation import StageTimer
from .stepping import StepJob

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

    Each simulation's CrowdSlot and steady intake are its own (``sim.steps``, core/stepping.py);
    the crowd keeps them in numba's typed lists for its calls, put again when one changes.

    :param threads: how many threads the call spreads over (0: all cores, as NUMBA_NUM_THREADS).
    """

    def __init__(self, threads: int = 0):
        self.threads = threads_for(threads)
        self.sims = []
        # The typed lists hold their items borrowed (crowd_steps.borrowed_list): never read
        # them from Python; the mirrors keep each item alive while its list holds it.
        self._slots = None          # a typed list of each simulation's CrowdSlot, once one
        self._mine = []             # the same slots, read from Python
        self._intakes = None                # each slot's SteadyIntake (a typed list)
        self._my_intakes = []               # the same, read from Python
        # Writes into the typed lists (crowd_steps.put_borrowed), rare: each checks the type,
        # as numba's typed.List did, so that an item of another type is refused, not misread.
        self._put_slot = FixedTypes(crowd_steps.put_borrowed, check=True)
        self._put_intake = FixedTypes(crowd_steps.put_borrowed, check=True)
        self._call = None
        self._steady = FixedTypes(crowd_steps.prepare_steady)
        self.calls = 0              # compiled calls made (one per round of inputs)
        self.steady_inputs = 0      # inputs the compiled intake took

    def add(self, sim: 'JacketSimulation') -> int:
        """Add a simulation; returns its index.

        :param sim: a simulation, stepped with the others from now on.
        """
        index = len(self.sims)
        self.sims.append(sim)
        self._set_slot(index, sim.steps.slot)
        self._set_intake(index, sim.steps.intake)
        if self._call is None:      # typed once: every slot has the same types
            self._call = FixedTypes(crowd_steps.advance_crowd)
            # Both loaded now, not on the first inputs: that stalled the first batch by
            # seconds and the first steady input by more than a step.
            none = np.zeros(0, dtype=np.int64)
            self._call(self._slots, none, none)
            self._steady(self._intakes, none, none, np.zeros(0), np.zeros(1, dtype=np.int64),
                         np.zeros(0, dtype=np.bool_))
            self._set_slot(index, sim.steps.slot)  # crowd_steps.put_borrowed loaded now too
            self._set_intake(index, sim.steps.intake)
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
        sims = self.sims
        fast, rest = [], []
        for item in inputs:
            index = item[1]
            sim = sims[index]
            steps = sim.steps
            if steps.ready_for(sim.steady_key(item[3]), item[2]):
                fast.append(item)
                if self._mine[index] is not steps.slot:
                    self._set_slot(index, steps.slot)
                if self._my_intakes[index] is not steps.intake:
                    self._set_intake(index, steps.intake)
            else:
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
                out.append((item[0], item[1], *sims[item[1]].steady_job(item[2])))
            else:
                sims[item[1]].steps.armed = None
                rest.append(item)
        self.steady_inputs += len(out)
        return out, rest

    def run(self, jobs: Sequence[tuple[int, 'StepJob']],
            loaded: frozenset = frozenset()) -> list[int]:
        """Run each (simulation index, prepared job) in one call; returns the status of each.

        The status is crowd_steps's (STEPS_FAILED, BONES_FINITE, BONES_NOT_FINITE); the steps
        and bones are in each simulation's slot, written again by its next job:
        JacketSimulation.finish takes them at once.

        :param jobs: (simulation index, job from prepare), at most one job per simulation.
        :param loaded: the simulations whose job :meth:`prepare_steady` loaded.
        """
        if not jobs:
            return []
        active = np.empty(len(jobs), dtype=np.int64)
        for j, (index, job) in enumerate(jobs):
            active[j] = index
            if index not in loaded:
                slot = self.sims[index].steps.load(job)
                if self._mine[index] is not slot:   # a new tuning, or the level of detail's
                    self._set_slot(index, slot)
        ran = np.zeros(len(jobs), dtype=np.int64)
        numba.set_num_threads(self.threads)
        # Characters handed out one at a time: a thread that the host slows takes fewer.
        numba.set_parallel_chunksize(1)
        self._call(self._slots, active, ran)
        self.calls += 1
        return ran.tolist()


def _put(items, mine, put, index, item):
    """Set ``item`` at ``index`` of a typed list and of its Python mirror (or append it).

    Returns the typed list, made by crowd_steps.borrowed_list for the first item (``items``
    None). The list's items are borrowed: the mirror keeps each alive while the list holds it.
    """
    if items is None:
        items = crowd_steps.borrowed_list(item)
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
        statuses = steps.run([(index, job) for _, index, job in jobs], loaded)
        for (k, index, job), status in zip(jobs, statuses):
            sim = sims[index]
            sim.finish(reports[k], job, status)
            sim.check_bones(reports[k])     # before settle: a reset is never steady
            sim.settle(inputs[k][2], reports[k])
        cost = time.perf_counter_ns() - started
        for k in this:
            reports[k].step_cost_ns = cost
        pending = later
        if after_round is not None:
            after_round(this, reports, not later)
    return reports
