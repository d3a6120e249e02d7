# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s host part: what the shared host's slow phases slow (``lab.host_probe``)."""

from jacket_cloth_ros.core.skeleton import Skeleton
from .. import host_probe
from .kernel import KERNEL_TARGET, Yardstick, limit_steps
from .measure import kernel_step_ns

PHASE_STATES = 20                  # captured states in one kernel measurement of host_phases
PHASE_YARDSTICK_STEPS = 210        # yardstick steps in one of its measurements there


def host_phases(skeleton: Skeleton, probe: host_probe.HostProbe, rounds: int,
                yardstick: Yardstick | None = None) -> dict:
    """Run host_probe.phases with the kernel (and the yardstick) at the target's grid and sweeps.

    Each kernel measurement is the median step over the first captured states, short enough
    for many rounds.

    :param skeleton: the shipped character.
    :param probe: the built host probe.
    :param rounds: how many rounds.
    :param yardstick: the built C yardstick; None: not measured.
    :returns: what host_probe.phases returns.
    """
    cols, nrows = (int(n) for n in KERNEL_TARGET['grid'].split('x'))
    it = KERNEL_TARGET['iterations']
    steps = limit_steps(skeleton)[:PHASE_STATES]
    # About as many yardstick steps as the kernel's measurement, over its timed blocks.
    ref = (lambda: yardstick.step_ns(cols, nrows, it, steps=PHASE_YARDSTICK_STEPS)[
        'step_ns_median'] * 1e-3) if yardstick else None
    return host_probe.phases(probe, lambda: kernel_step_ns(steps, repeat=1) * 1e-3, rounds,
                             yardstick_us=ref)
