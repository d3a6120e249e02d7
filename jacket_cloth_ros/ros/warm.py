# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth warm``: compile every kernel the node uses into numba's cache, ahead.

numba compiles a kernel on its first call and caches it on disk; without this the node's
first start after an install (or an edit of a kernel file) spends that time before its first
/tf. ``make`` runs it on set-up; on a ROS install, run it once after ``colcon build``.
"""

import time

from ..core.fabric import load_fabrics
from ..core.physics import crowd as crowd_physics, step
from ..core.rig import load_rig
from ..core.skeleton import load_shipped_character
from ..motion.clips import joint_state_content
from . import cdr, steady_lane
from .pipeline import CrowdPipeline, SessionPipeline
from .values import default_values


def kernels_cached(crowd: bool = True) -> bool:
    """Tell whether numba's cache holds the compiled step for the kernel files as they are.

    If not, the next simulation made compiles every kernel, which takes a while.

    :param crowd: whether the crowd's one call for many characters (jacket_cloth_crowd) counts
        too.
    """
    wanted = (step.advance, steady_lane.steady_tf)
    if crowd:
        wanted += (crowd_physics.advance_crowd, crowd_physics.prepare_steady)
    try:
        return all(bool(k._cache._cache_file._load_index()) for k in wanted)
    except Exception:  # noqa: BLE001 - numba's cache internals: unknown means not cached
        return False


def warm_kernels(crowd: bool = True) -> tuple:
    """Load, or compile and cache, every kernel of the node's per-input path.

    :param crowd: whether the crowd's one call for many characters is warmed too
        (jacket_cloth_crowd; a single node leaves it out, its first start needs only its own).
    :returns: (seconds taken, whether they were cached already).
    """
    cached = kernels_cached(crowd)
    started = time.perf_counter()
    skeleton = load_shipped_character()
    fabrics = load_fabrics()
    pipeline = SessionPipeline(skeleton, load_rig(skeleton),
                               default_values(fabrics['tweed_jacket']))
    names, positions = joint_state_content(skeleton.joint_names, 'walk', 0.0)
    for k in range(4):      # a reset, steps, then steady inputs: every output of an input
        pipeline.on_raw(cdr.joint_state(10**9 + k * 10**7, names, positions))
    if not crowd:
        return time.perf_counter() - started, cached
    # The crowd's one call for many characters (jacket_cloth_crowd), compiled on its own.
    many = CrowdPipeline()              # of two: a crowd of one steps its character alone
    for _ in range(2):
        many.add(SessionPipeline(skeleton, load_rig(skeleton),
                                 default_values(fabrics['tweed_jacket'])))
    reader = cdr.JointStateReader()     # one name list: the fourth input takes the steady way
    for k in range(4):
        content = reader.read(cdr.joint_state(10**9 + k * 10**7, names, positions))
        many.on_joint_states([(0, content), (1, content)])
    return time.perf_counter() - started, cached
