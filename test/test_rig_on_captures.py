# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Issue 18 done on real captures: import, propose the rig, replay, and the figures hold.

No rig key typed by hand: each capture ``make`` fetches (bvhtoolbox 0.1.3's MocapBank and
free-BVH files, see test_mocap_targets.py) goes through ``jacket_cloth import`` and
``jacket_cloth rig``, then the replay's pipeline at the default settings with the proposed rig,
measured after every input as ``jacket_cloth analyze`` measures it (core.measures).
"""


import numpy as np
import pytest
import yaml

from jacket_cloth_ros.tools.cli import main
from jacket_cloth_ros.tools.session import load_session
from fetched import fetched
from per_input import measure_every_input


@pytest.fixture(scope='module', params=['test_freebvh.bvh', 'test_mocapbank.bvh'])
def proposed(request, tmp_path_factory):
    """Import a capture, propose its rig, replay it and measure after every input."""
    path = fetched(request.param)
    tmp = tmp_path_factory.mktemp('proposed')
    session, urdf, rig = tmp / 'session.mcap', tmp / 'skeleton.urdf', tmp / 'rig.yaml'
    assert main(['import', path, '-o', str(session), '--urdf-out', str(urdf)]) == 0
    assert main(['rig', '--urdf', str(urdf), '-o', str(rig)]) == 0
    loaded = load_session(str(session), urdf=str(urdf), rig=str(rig))
    s = measure_every_input(loaded)
    assert s['inputs'] == len(s['vertical_stretch']) > 60
    with open(rig, encoding='utf-8') as f:
        text = yaml.safe_load(f)
    return request.param, s, text


def test_a_proposed_rig_holds_the_jacket_unstretched_and_outside_on_a_real_capture(proposed):
    # Issue 19 item 3's limits, as the hand-fitted rigs hold them (test_mocap_targets.py).
    name, s, _ = proposed
    vertical, inside = s['vertical_stretch'], s['inside_m']
    assert vertical.max() <= 0.10 and np.percentile(vertical, 99) <= 0.03, name
    assert inside.max() <= 0.01 and np.percentile(inside, 99) <= 0.003, name
    # Issue 35: the same inside the body proxy, which does not see the rig's colliders. Before
    # the colliders covered each leg bone whole (thighs from 0.07 to 0.82 of the bone, no
    # shins), the free-BVH hem was 49.6 mm inside a knee and the seated MocapBank's 36.9 mm
    # inside an ankle.
    body = s['body_inside_m']
    assert body.max() <= 0.01 and np.percentile(body, 99) <= 0.003, name


def test_a_proposed_rig_holds_the_horizontal_target_on_real_captures(proposed):
    # Issue 19's horizontal target (p99 <= 10 %), as the hand-fitted rigs hold it
    # (test_mocap_targets.py). Before the proposer put M11 references on the trunk only and
    # sized the thigh and torso colliders thinner than the flesh, the MocapBank capture
    # reached 0.77 (p99 0.76): the sitting thighs pulled the hem's halves apart.
    name, s, rig = proposed
    assert np.percentile(s['horizontal_stretch'], 99) <= 0.10, name
    assert len(rig['cloth']['reference_bones']) == 2            # trunk: shape link and pelvis
