# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What every part of ``bench speed`` times with: the host's steal, the bare kernel's step.

The kernel's arguments captured along a clip (:func:`captured_steps`), their median step
(:func:`kernel_step_ns`) and a measurement between two rounds of it (:func:`beside_kernel`):
the kernel-only limit each part is set against, timed in the same phase of the host.
"""

import time
from typing import Any, Callable, Sequence

import numpy as np

from ..proc import cpu_ticks
from jacket_cloth_ros.core.bundles import copied
from jacket_cloth_ros.core.compiled import FixedTypes
from jacket_cloth_ros.core.fabric import Fabric
from jacket_cloth_ros.core.physics import cloth
from jacket_cloth_ros.core.rig import Rig
from jacket_cloth_ros.core.simulation import JacketSimulation
from jacket_cloth_ros.core.skeleton import Skeleton
from ..accuracy import clip_inputs

RATE = 120.0                   # JointState Hz of the node runs, as the issue sets
STEP_US = 1e6 / RATE           # one step: the latency target
ROUND_REPEATS = 20                 # passes over the captured states in one kernel round


class Steal:
    """The share of CPU time the hypervisor gave to other guests while a section ran.

    Why: on a shared virtual machine a figure measured while the host takes 20 % of the time
    is not the code's; each section of the bench says how much was taken (seen idle here:
    9-25 %).
    """

    def __enter__(self) -> 'Steal':
        self._start = cpu_ticks()
        self.percent = float('nan')
        return self

    def __exit__(self, *exc: object) -> bool:
        """Take the share since ``__enter__`` into ``percent``; let any exception through.

        :param exc: the exception's type, value and traceback, if one ended the section.
        """
        steal, total = (b - a for a, b in zip(self._start, cpu_ticks()))
        self.percent = 100.0 * steal / total if total else float('nan')
        return False


def captured_steps(skeleton: Skeleton, rig: Rig, fabric: Fabric, clip: str = 'walk',
                   seconds: float = 1.0) -> list[tuple]:
    """Return the kernel's arguments after each input of a clip.

    One step of the state and pose the simulation reached there
    (JacketSimulation.kernel_arguments).

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset.
    :param clip: a name of ``clips.ALL_CLIPS``.
    :param seconds: how long.
    """
    sim = JacketSimulation(skeleton, rig, fabric)
    captured = []
    for stamp, names, pos in clip_inputs(skeleton, clip, seconds):
        sim.process(stamp, names, pos)
        captured.append(copied(sim.kernel_arguments()))
    return captured[2:]             # past the reset and the first step after it


def kernel_step_ns(steps: Sequence[tuple], repeat: int = 3) -> float:
    """Median time of the kernel on each captured state (copies made outside the timing).

    :param steps: ``cloth_step``'s arguments, one tuple per captured state.
    :param repeat: how many times each state is timed.
    """
    times = []
    step = FixedTypes(cloth.cloth_step, check=False)   # typed once, as the simulation does
    for _ in range(repeat):
        for args in steps:
            a = copied(args)
            t0 = time.perf_counter_ns()
            step(*a)
            times.append(time.perf_counter_ns() - t0)
    return float(np.median(times))


def beside_kernel(steps: Sequence[tuple], measure: Callable[[], Any]) -> tuple[Any, float]:
    """Run ``measure`` between two rounds of the bare kernel: the host's phase it ran in.

    :param steps: the kernel's arguments (:func:`limit_steps`).
    :param measure: what to run.
    :returns: what ``measure`` returned, and the mean of the two rounds' median steps, ns.
    """
    before = kernel_step_ns(steps, repeat=ROUND_REPEATS)
    got = measure()
    after = kernel_step_ns(steps, repeat=ROUND_REPEATS)
    return got, (before + after) / 2.0
