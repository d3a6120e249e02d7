# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A loaded session replayed and measured after every input, as ``jacket_cloth analyze`` does.

Shared by the tests that hold issue 19's per-input targets on real captures and proposed
rigs (test_mocap_targets, test_rig_on_captures, test_public_humanoid, test_deepmimic_clips).
"""

import numpy as np

from jacket_cloth_ros.core.body_proxy import body_proxy, sleeved_links
from jacket_cloth_ros.core.measures import collider_labels, depth_inside, depth_under_floor
from jacket_cloth_ros.ros import messages
from jacket_cloth_ros.tools.session import run_session


def measure_every_input(loaded, keep_x: bool = False) -> dict:
    """Replay ``loaded`` (tools.session.load_session) and measure the cloth after each input.

    Returns numpy arrays ``vertical_stretch``, ``horizontal_stretch``, ``inside_m`` (the rig's
    colliders), ``body_inside_m`` (the body proxy, every vertex, as analyze's),
    ``hood_under_plane_m`` (the M8 hood particle's depth under the rig's planes),
    ``drawn_under_floor_m`` (the markers' jacket's depth under the rig's floor) (and ``x``, the
    cloth per input, with ``keep_x``), the list ``resets`` (reasons), and the
    counts ``published`` (inputs that put bones on /tf) and ``inputs``, and ``rig_faults``:
    what the simulation said of the rig and the body at the start. Every input must be
    accepted and leave a finite cloth.
    """
    labels = collider_labels(loaded.setup.rig)
    body = body_proxy(loaded.setup.skeleton, sleeved_links(loaded.setup.rig))
    everywhere = np.ones(loaded.setup.rig.n, dtype=bool)
    series = {'vertical_stretch': [], 'horizontal_stretch': [], 'inside_m': [],
              'body_inside_m': [], 'hood_under_plane_m': [], 'drawn_under_floor_m': [],
              'x': []}
    resets, published = [], 0

    def probe(pipeline, report, stamp, outputs):
        nonlocal published
        sim = pipeline.sim
        assert report.accepted and np.isfinite(sim.x).all()
        published += any(key == 'tf' for key, _ in outputs)
        if report.reset:
            resets.append(report.reset)
        vs, _, hs, _ = sim.edge_strains()
        series['vertical_stretch'].append(vs.value)
        series['horizontal_stretch'].append(hs.value)
        frames = sim.collider_frames(sim.links)
        series['inside_m'].append(depth_inside(sim.x, sim.rig.free, frames, labels).value)
        series['body_inside_m'].append(depth_inside(sim.x, everywhere, body.posed(sim.links),
                                                    body.labels).value)
        series['hood_under_plane_m'].append(max(
            [0.0, *(-(sim.hood_p - frames.plane_points) * frames.plane_normals).sum(axis=1)]))
        series['drawn_under_floor_m'].append(_drawn_under_floor(sim))
        if keep_x:
            series['x'].append(sim.x.copy())

    pipeline = run_session(loaded, probe=probe)
    if not keep_x:
        del series['x']
    out = {k: np.array(v) for k, v in series.items()}
    return out | {'resets': resets, 'published': published, 'inputs': pipeline.inputs,
                  'rig_faults': list(pipeline.sim.faults.rig)}


def _drawn_under_floor(sim):
    """How far the jacket the markers draw reaches under the rig's floor, m (0 without one)."""
    floor = sim.rig.floor()
    if floor is None:
        return 0.0
    [jacket] = [m.points for m in messages.marker_specs(sim, body=False) if m.ns == 'jacket']
    return depth_under_floor(jacket, sim.root, floor)
