# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The compiled step (physics.step.advance) does what the step did as numpy and separate parts."""

import numpy as np
import pytest
from conftest import clip_inputs

from jacket_cloth_ros.core.physics import cloth, pose, step
from jacket_cloth_ros.core.simulation import DESIGN_RATE, per_step
from jacket_cloth_ros.core.transforms import (
    apply_transform, invert_transform, make_transform, quat_slerp, quat_to_matrix)


def test_compiled_slerp_and_rotation_equal_the_numpy_ones():
    rng = np.random.default_rng(3)
    out, m = np.empty(4), np.empty((4, 4))
    for k in range(200):
        a = rng.normal(size=4)
        a /= np.linalg.norm(a)
        # Far apart, opposite hemispheres, and nearly equal (the linear branch).
        b = rng.normal(size=4) if k % 3 else a + 1e-5 * rng.normal(size=4)
        b /= np.linalg.norm(b)
        t = rng.uniform()
        pose.quat_slerp(a, b, t, out)
        assert np.allclose(out, quat_slerp(a, b, t), atol=1e-12)
        pose.quat_matrix(3.0 * a, m)          # normalises as quat_to_matrix does
        assert np.allclose(m[:3, :3], quat_to_matrix(a), atol=1e-12)


def _reference_steps(sim, a, b, n):
    """M7, M14, M2/M6/M11, M10, the cloth and M8 as _step ran them before the fusion: numpy
    transforms between separately compiled parts."""
    p, f, rig = sim.params, sim.fabric, sim.rig
    e = DESIGN_RATE / p.sim_rate
    dt = sim.dt_ns * 1e-9
    for _ in range(n):
        sim.t_sim += sim.dt_ns
        w = min(1.0, max(0.0, (sim.t_sim - a.stamp_ns) / (b.stamp_ns - a.stamp_ns)))
        root = make_transform(quat_to_matrix(quat_slerp(a.root_quat, b.root_quat, w)),
                              a.root[:3, 3] + w * (b.root[:3, 3] - a.root[:3, 3]))
        links = sim.skeleton.forward(a.q + w * (b.q - a.q))
        delta = invert_transform(root) @ sim.root
        share_x = sim.tuning.world_share[:, None]
        for points, share in ((sim.x, share_x), (sim.xp, share_x),
                              (sim.hood_p[None], f.world_share),
                              (sim.hood_pp[None], f.world_share)):
            points += share * (apply_transform(delta, points) - points)
        sim.root, sim.links = root, links
        layer = rig.layer.solve(links)
        top, ref = sim.pinned_points(links, layer), sim.reference_points(links, layer)
        sim.x[:rig.cols] = top
        sim.xp[:rig.cols] = top
        to_local = root[:3, :3].T
        gravity = to_local @ np.array([0.0, 0.0, -p.gravity])
        wind = to_local @ p.wind_at(sim.t_sim)
        cloth.cloth_step(*sim.kernel_arguments(
            links, root, ref, gravity + sim.tuning.wind_scale[:, None] * wind,
            per_step(sim.tuning.damping, e), float(per_step(f.contact_damping, e)), dt))
        sim.hood_step(links, gravity + f.wind_scale * wind, dt,
                      float(per_step(f.hood_damping, e)))


def test_one_compiled_call_steps_as_the_separate_parts_did(make_sim, skeleton):
    # 60 Hz inputs at a 120 Hz step: each input interpolates a step between two samples (M7).
    params = dict(wind=(2.0, 1.0, 0.0), wind_gust=0.5)
    fused, reference = make_sim(**params), make_sim(**params)
    inputs = (clip_inputs(skeleton, 'turn', 0.6)
              + clip_inputs(skeleton, 'dodge', 0.6, start_s=10.6))
    stamp, names, pos = inputs[0]
    for sim in (fused, reference):
        sim.process(stamp, names, pos)
    last = reference.last
    for stamp, names, pos in inputs[1:]:
        report = fused.process(stamp, names, pos)
        assert report.steps == 2 and not report.reset
        sample = reference.parser.parse(stamp, names, pos)
        _reference_steps(reference, last, sample, 2)
        last = sample
    assert np.abs(fused.root - reference.root).max() < 1e-12        # the character moved
    assert np.linalg.norm(fused.root[:3, 3]) > 0.1
    assert np.abs(fused.links - reference.links).max() < 1e-12
    assert np.abs(fused.x - reference.x).max() < 1e-9
    assert np.abs(fused.hood_p - reference.hood_p).max() < 1e-9
    moved = np.abs(fused.x - fused.rig.rest).max()
    assert moved > 0.05                                              # not a cloth at rest


def test_the_cached_step_is_marked_with_the_cloth_kernels_source_too():
    # advance compiles cloth.cloth_step into itself; numba marks a cache with its own file
    # only, so an edit of cloth.py went on running the old cloth step from the cache.
    import hashlib
    stamp = step.advance._cache._impl._locator.get_source_stamp()
    with open(cloth.__file__, 'rb') as f:
        assert hashlib.sha256(f.read()).digest() in stamp


def test_every_module_with_cached_kernels_is_marked_by_all_kernel_files():
    # A kernel module left out of compiled.kernel_files (or taking njit straight from numba)
    # would be cached against its own file only again.
    import pathlib
    import re
    from jacket_cloth_ros.core import compiled
    package = pathlib.Path(compiled.__file__).parent.parent
    with_kernels = {str(p) for p in package.rglob('*.py')
                    if re.search(r'^@njit', p.read_text(), re.MULTILINE)}
    # bundles.py holds no kernel, but the compiled code depends on its fields' order.
    bundles = str(package / 'core' / 'bundles.py')
    assert with_kernels | {bundles} <= set(compiled.kernel_files())
    # The marks cover this package's files only: a lab kernel compiling ours in would be
    # cached against its own file and run our old code after an edit.
    lab = package.parent / 'jacket_cloth_lab'
    assert not [p for p in lab.rglob('*.py') if 'njit' in p.read_text()]
    for path in with_kernels:
        text = pathlib.Path(path).read_text()
        assert re.search(r'compiled import .*\bnjit\b', text), path
        assert 'from numba import njit' not in text, path


def test_a_borrowed_bundle_reads_and_writes_its_arrays_and_counts_no_reference():
    # The steps run on borrowed bundles: every array must still be the caller's memory, each
    # scalar kept, while numba's atomic reference count is skipped (no meminfo to count on).
    from numba import njit, types
    from numba.core import cgutils
    from numba.extending import intrinsic
    from numba.np.arrayobj import make_array
    from jacket_cloth_ros.core.bundles import Motion
    from jacket_cloth_ros.core.compiled import borrowed

    @intrinsic
    def counted(typingctx, array):
        def codegen(context, builder, signature, args):
            meminfo = make_array(signature.args[0])(context, builder, value=args[0]).meminfo
            return builder.icmp_unsigned('!=', meminfo, cgutils.get_null_value(meminfo.type))
        return types.boolean(array), codegen

    @njit
    def through(motion):
        lent = borrowed((motion, motion.q_a))
        lent[0].q_b[1] = lent[0].q_a[0] + lent[0].steps
        return counted(motion.q_a), counted(lent[0].q_a), counted(lent[1]), lent[0].dt_ns

    arrays = [np.array([1.0, 2.0]), np.zeros(2)] + [np.zeros(3) for _ in range(4)]
    motion = Motion(*arrays, 5, 6, 7, 8, 9)
    assert through(motion) == (True, False, False, 8)
    assert motion.q_b[1] == 1.0 + 9


def test_the_borrowed_lists_hold_what_their_python_mirrors_keep_alive(skeleton, rig):
    # A crowd's typed lists and a lone character's lane hold their bundles borrowed: each item
    # must be the memory of the object its Python mirror holds, whatever was added, retuned,
    # re-armed or collected since; an item whose mirror went would be freed memory.
    import gc
    from numba import njit
    from jacket_cloth_ros.core.crowd import CrowdSteps, stepped
    from jacket_cloth_ros.core.fabric import load_fabric
    from jacket_cloth_ros.core.simulation import JacketSimulation

    @njit
    def slot_memory(items, i):
        return items[i].state.x.ctypes.data, items[i].state.x[-1, 2]

    @njit
    def intake_memory(items, i):
        return items[i].last.q.ctypes.data

    @njit
    def lane_memory(lane):
        return lane[0][0].ctypes.data, lane[0][3].state.x.ctypes.data

    crowd = CrowdSteps(threads=2)
    sims = [JacketSimulation(skeleton, rig, load_fabric('tweed_jacket')) for _ in range(3)]

    def check():
        gc.collect()
        for i in range(len(crowd.sims)):
            mine = crowd._mine[i].state.x
            assert slot_memory(crowd._slots, i) == (mine.ctypes.data, mine[-1, 2]), i
            assert intake_memory(crowd._intakes, i) == crowd._my_intakes[i].last.q.ctypes.data
        for sim in crowd.sims:
            lent = sim.steps._lent
            assert lane_memory(sim.steps.lane) == (lent[0].ctypes.data,
                                                   lent[3].state.x.ctypes.data)
            # An unarmed lane takes no input: it may hold the slot before a new tuning.
            if sim.steps.armed is not None:
                assert lent[2] is sim.steps.intake and lent[3] is sim.steps.slot
                armed.add(id(sim))
    armed = set()
    crowd.add(sims[0])
    for k, (stamp, names, pos) in enumerate(clip_inputs(skeleton, 'walk', 0.5)):
        if k in (5, 12):
            crowd.add(sims[1 if k == 5 else 2])
        if k == 20:
            sims[1].set_params(sims[1].params.with_values(substeps=2))     # a new tuning
        names = tuple(names)            # a list could change: never steady
        stepped(crowd, [(i, stamp, names, pos) for i in range(len(crowd.sims))])
        check()
    assert crowd.steady_inputs > 0 and len(crowd._mine) == 3 and len(armed) == 3


def test_fixed_types_refuses_a_call_whose_types_changed():
    # The entry point of a kernel typed once would read a changed argument as the old type.
    from jacket_cloth_ros.core.compiled import CHECK_TYPES, FixedTypes
    assert CHECK_TYPES                      # conftest checks every call in the tests
    call = FixedTypes(step.lost_per_each)
    out = np.empty(3)
    call(np.full(3, 0.5), 0.5, out)
    assert out == pytest.approx(1 - 0.5 ** 0.5)
    with pytest.raises(TypeError, match='argument types changed'):
        call(np.full(3, 1, dtype=np.int64), 0.5, out)


def test_the_compiled_step_is_typed_once_whatever_values_the_parameters_take(make_sim, skeleton):
    # Bundles fix every dtype: ints where floats are meant, a live change, arrays a caller
    # assigned in another order, and another rig (capsules, a floor, another skeleton) all
    # give the types the step was first compiled for.
    from numba import typeof
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.core.fabric import load_fabric
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.simulation import JacketSimulation
    from jacket_cloth_ros.core.skeleton import load_skeleton
    sim = make_sim()
    inputs = clip_inputs(skeleton, 'walk', 0.3)
    for k, (stamp, names, pos) in enumerate(inputs):
        if k == 5:
            sim.set_params(sim.params.with_values(wind=(1, 0, 0), wind_gust=1, gravity=10,
                                                  quality_tolerance=0, substeps=2))
            sim.x = np.asfortranarray(sim.x)
            sim.hood_p = sim.hood_p.astype(np.float32)
        assert not sim.process(stamp, names, pos).warnings
    assert sim.steps.advance._types is not None and sim.steps.steady._types is not None
    other_skeleton = load_skeleton(shipped('examples/mannequin.urdf'))
    other = JacketSimulation(other_skeleton,
                             load_rig(other_skeleton, shipped('examples/mannequin_rig.yaml')),
                             load_fabric('tweed_jacket'))
    assert other.rig.capsule_links.size and other.rig.plane_links.size
    for ours, theirs in ((sim.model, other.model), (sim.tuning, other.tuning),
                         (sim.state, other.state)):
        assert typeof(ours) == typeof(theirs)
