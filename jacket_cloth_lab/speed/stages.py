# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s profile part: where one input's CPU goes, beside the kernel-only limit."""

from jacket_cloth_ros.core.skeleton import Skeleton
from .. import profile
from .kernel import limit_steps
from .measure import beside_kernel


def profiled(skeleton: Skeleton, seconds: float, node: bool) -> dict:
    """Return :func:`profile.per_input_profile` with the bare kernel's step timed beside it.

    The walk runs twice, each run between two rounds of the bare kernel: with the stage
    timers, for where the time goes, then without them, for the main thread's share of the
    kernel-only limit (:func:`profile.main_thread_share`), which the timers' own cost would
    lower.

    :param skeleton: the shipped character.
    :param seconds: the walk's length.
    :param node: whether the node's take and publish are added.
    :returns: the profile, its ``kernel_step_us`` and ``untimed``: the run without the stage
        timers (``us_per_input``, ``us`` with the node's take and publish) and its own
        ``kernel_step_us``.
    """
    steps = limit_steps(skeleton)
    got, kernel_ns = beside_kernel(steps, lambda: profile.per_input_profile(
        skeleton, seconds, node=node))
    bare, bare_ns = beside_kernel(steps, lambda: profile.per_input_profile(
        skeleton, seconds, node=node, stages=False))
    return dict(got, kernel_step_us=kernel_ns / 1e3, untimed={
        'us_per_input': bare['us_per_input'], 'us': bare['us'], 'kernel_step_us': bare_ns / 1e3})
