# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Level of detail by distance to a viewer (issue 19 item 5, core/lod.py)."""

import json

import numpy as np
import pytest

from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.motion.clips import joint_state_content

RATE = 60.0


def _walk(skeleton, rig, viewer_at, seconds=3.0, **params):
    """Run the walk with the viewer ``viewer_at(t)`` metres ahead; per input x, report."""
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'), SimParams(**params))
    xs, reports = [], []
    for k in range(int(seconds * RATE)):
        t = k / RATE
        names, pos = joint_state_content(skeleton.joint_names, 'walk', t)
        root = np.array(pos[len(skeleton.joint_names):len(skeleton.joint_names) + 3])
        d = viewer_at(t)
        sim.set_viewer(None if d is None else root + [d, 0.0, 0.0])
        reports.append(sim.process(int((10.0 + t) * 1e9), names, pos))
        xs.append(sim.x.copy())
    return sim, np.array(xs), reports


def _largest_jump(xs, rows=slice(None)):
    return np.linalg.norm(np.diff(xs, axis=0)[:, :, :][rows], axis=2).max()


def test_a_near_viewer_changes_nothing(skeleton, rig):
    _, free, _ = _walk(skeleton, rig, lambda t: None, 1.0)
    _, near, reports = _walk(skeleton, rig, lambda t: 2.0, 1.0)
    assert np.array_equal(free, near)
    assert {r.lod_level for r in reports} == {0}


def test_far_characters_run_fewer_sweeps_and_then_none(skeleton, rig):
    _, _, mid = _walk(skeleton, rig, lambda t: 20.0, 1.0)
    _, _, near = _walk(skeleton, rig, lambda t: 2.0, 1.0)
    assert sum(r.sweeps for r in mid[1:]) * 2 == sum(r.sweeps for r in near[1:])
    sim, xs, far = _walk(skeleton, rig, lambda t: 50.0, 1.5)
    assert far[-1].lod_level == 2 and far[-1].sweeps == 0 and far[-1].steps == 2
    # Beyond far the cloth rides on its top row: each column moves as its top vertex does.
    column = np.arange(rig.n) % rig.cols
    offset = sim.x - sim.x[column]
    sim.process(int(11.5e9), *joint_state_content(skeleton.joint_names, 'walk', 1.5))
    assert np.allclose(sim.x - sim.x[column], offset, atol=1e-12)
    assert not np.allclose(sim.x, xs[-1])


def test_a_level_keeps_handing_the_same_tuning_while_it_holds(skeleton, rig):
    # A crowd replaces a character's compiled slot whenever its tuning object changes: a new
    # one per input cost the far characters most of what their level saves (docs/crowd.md).
    from jacket_cloth_ros.core.lod import LevelOfDetail, LodStep
    sim, _, _ = _walk(skeleton, rig, lambda t: 50.0, 0.1)
    lod, far, mid = LevelOfDetail(), LodStep(2, 1.0, 1.0), LodStep(1, 0.0, 0.0)
    held = lod.tuned(sim.tuning, far)
    assert held == LevelOfDetail.tuning(sim.tuning, far) and held != sim.tuning
    assert lod.tuned(sim.tuning, LodStep(2, 1.0, 1.0)) is held
    assert lod.tuned(sim.tuning, mid) == LevelOfDetail.tuning(sim.tuning, mid)
    changed = sim.tuning._replace(iterations=sim.tuning.iterations + 1)
    assert lod.tuned(changed, far).iterations == changed.iterations // 2


def test_a_level_change_blends_without_a_pop(skeleton, rig):
    # The viewer walks away at 1 s and back at 2 s: no vertex jumps further in one input than
    # the cloth moves anyway in the walk at full detail.
    _, full, _ = _walk(skeleton, rig, lambda t: None)
    _, lod, reports = _walk(skeleton, rig, lambda t: 50.0 if 1.0 <= t < 2.0 else 2.0)
    levels = [r.lod_level for r in reports]
    assert levels.count(2) > 30 and levels[-1] == 0
    normal = np.linalg.norm(np.diff(full[1:], axis=0), axis=2).max()
    changing = np.linalg.norm(np.diff(lod[1:], axis=0), axis=2).max()
    assert changing <= normal, (changing, normal)
    # Without the blend (a blend shorter than a step) the same change pops.
    _, popped, _ = _walk(skeleton, rig, lambda t: 50.0 if 1.0 <= t < 2.0 else 2.0,
                         lod_blend_s=0.01)
    assert np.linalg.norm(np.diff(popped[1:], axis=0), axis=2).max() > normal


def test_the_same_viewer_inputs_give_the_same_cloth(skeleton, rig):
    # The viewer is an input: a replay feeding the same positions reproduces every step.
    moving = lambda t: 5.0 + 30.0 * t       # noqa: E731
    _, a, _ = _walk(skeleton, rig, moving, 1.5)
    _, b, _ = _walk(skeleton, rig, moving, 1.5)
    assert np.array_equal(a, b)


def test_lod_distances_are_checked():
    with pytest.raises(ValueError, match='lod_distances'):
        SimParams(lod_distances=(10.0, -1.0))


def test_bench_lod_charts_error_against_distance(tmp_path):
    from jacket_cloth_lab.cli import main
    assert main(['bench', 'lod', '--quick', '--out', str(tmp_path)]) == 0
    rows = json.loads((tmp_path / 'lod.json').read_text())['rows']
    assert [r['level'] for r in rows] == [0, 0, 1, 1, 2, 2]
    assert rows[1]['cloth_rms_m'] == 0.0 < rows[2]['cloth_rms_m'] < rows[4]['cloth_rms_m']
    assert (tmp_path / 'lod.png').stat().st_size > 10_000
    # The crowd (issue 23 item 5): 4 and 16 characters evenly from 0 to 60 m, each at the
    # level its distance gives at every input after the first (coming from level 0, a level
    # is entered 10 % past its boundary: 32 m is still level 1), charted on and off.
    crowd = json.loads((tmp_path / 'crowd_lod.json').read_text())['rows']
    inputs = 29                                       # 0.5 s at 60 Hz, the reset left out
    levels = [[1, 1, 2], [3, 6, 7]]                   # characters per level
    assert [r['inputs_per_level'] for r in crowd] == [[inputs * n for n in row]
                                                      for row in levels]
    assert all(r['us_per_character_on'] > 0 and r['us_per_character_off'] > 0 for r in crowd)
    assert (tmp_path / 'crowd_lod.png').stat().st_size > 10_000
    # The docs' tables of this bench, written from this run.
    from doc_tables import rewritten
    tables = rewritten(tmp_path, {'bench_lod': tmp_path}, ('lod.latest', 'crowd.lod'))
    assert '| 60 | 2 |' in tables['lod.latest'] and '| 16 |' in tables['crowd.lod']
