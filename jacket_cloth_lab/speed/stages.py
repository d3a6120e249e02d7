# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s profile part: where one input's CPU goes, beside the kernel-only limit."""

from jacket_cloth_ros.core.skeleton import Skeleton
from .. import profile
from .kernel import limit_steps
from .measure import beside_kernel


def profiled(skeleton: Skeleton, seconds: float, node: bool) -> dict:
    """Return :func:`profile.per_input_profile` with the bare kernel's step timed beside it.

    :param skeleton: the shipped character.
    :param seconds: the walk's length.
    :param node: whether the node's take and publish are added.
    :returns: the profile and its ``kernel_step_us``.
    """
    got, kernel_ns = beside_kernel(limit_steps(skeleton), lambda: profile.per_input_profile(
        skeleton, seconds, node=node))
    return dict(got, kernel_step_us=kernel_ns / 1e3)
