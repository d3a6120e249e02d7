# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Issue 19's targets held on real motion capture, not on motion written here.

Each capture ``make`` fetches (bvhtoolbox 0.1.3's MocapBank and free-BVH files, see
test_bvh_import.py and docs/motion_capture.md) goes through ``jacket_cloth import``, then the
replay's pipeline at the default settings with its rig from config/examples, measured after
every input as ``jacket_cloth analyze`` measures it (core.measures). Whole captures: 455 inputs
(15 s, sitting down and standing up) and 69 inputs (2.3 s).
"""

import os

import numpy as np
import pytest

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.tools.cli import main
from jacket_cloth_ros.tools.session import load_session
from fetched import fetched
from per_input import measure_every_input

EXAMPLES = os.path.join(os.path.dirname(shipped('character.urdf')), 'examples')
CAPTURES = {'test_mocapbank.bvh': 'mocapbank_rig.yaml', 'test_freebvh.bvh': 'freebvh_rig.yaml'}


@pytest.fixture(scope='module', params=sorted(CAPTURES))
def measured(request, tmp_path_factory):
    """Import, replay at the default settings, and measure one capture after every input."""
    path = fetched(request.param)
    tmp = tmp_path_factory.mktemp('capture')
    session, urdf = tmp / 'session.mcap', tmp / 'skeleton.urdf'
    assert main(['import', path, '-o', str(session), '--urdf-out', str(urdf)]) == 0
    loaded = load_session(str(session), urdf=str(urdf),
                          rig=os.path.join(EXAMPLES, CAPTURES[request.param]))
    series = measure_every_input(loaded)
    return request.param, series


def test_every_input_of_a_real_capture_holds_the_jacket_unstretched_and_outside(measured):
    # Issue 19 item 3 at the default settings: no vertical edge over 10 % at any input (p99
    # 3 %), the published cloth never over 1 cm inside a collider (p99 3 mm), and no reset but
    # the first sample's. Before the pinned row was kept outside the colliders and the
    # MocapBank rig was fitted, that capture reached 12.1 % (p99 10.7 %) and 4.8 mm.
    name, s = measured
    assert s['published'] == s['inputs'] == len(s['vertical_stretch'])
    assert s['resets'] == ['first sample']
    stretch, inside = np.array(s['vertical_stretch']), np.array(s['inside_m'])
    assert stretch.max() <= 0.10 and np.percentile(stretch, 99) <= 0.03, name
    assert inside.max() <= 0.01 and np.percentile(inside, 99) <= 0.003, name


def test_horizontal_stretch_of_a_real_capture_is_within_the_target(measured):
    # Issue 19's horizontal target: p99 <= 10 % over rest. Before the horizontals' strain
    # limit (after M12, then M12 again) both captures were at about 20 % p99 (0.20 / 0.20).
    name, s = measured
    assert np.percentile(s['horizontal_stretch'], 99) <= 0.10, name
