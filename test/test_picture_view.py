# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Pictures in the world, following the character (issue 18 item 4).

The filmstrip draws each frame in a Z-up world view centred on the character's body link at
its moment, whatever the root link's axes and however the character moves through the world
(the world joint, or the URDF's own joints). Asserted on the view coordinates the drawing uses.
"""

import numpy as np
import pytest
from conftest import clip_inputs
from reframe import Y_UP, root_link, rotate_joint_state, rotate_rig, rotate_urdf

from jacket_cloth_ros.core.config import load_yaml, shipped
from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.rig import Rig
from jacket_cloth_ros.core.simulation import JacketSimulation
from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
from jacket_cloth_ros.tools.picture import (
    axis_label, body_link, draw_filmstrip, in_view, sim_frame, view_axes_of)

# The shipped character on a rail: its own prismatic joint walks it along the world's x.
RAIL = '''<link name="rail"/>
  <joint name="rail_x" type="prismatic">
    <parent link="rail"/>
    <child link="base_link"/>
    <origin xyz="0 0 0.96" rpy="0 0 0"/>
    <axis xyz="1 0 0"/>
    <limit lower="-100" upper="100" effort="1" velocity="10"/>
  </joint>
  <link name="base_link"/>'''


def _frames(urdf, rig_data, inputs, turn=None, rail=False):
    skeleton = Skeleton(urdf)
    rig = Rig(rig_data, skeleton)
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'))
    frames = []
    for k, (stamp, names, pos) in enumerate(inputs):
        if turn is not None:
            pos = rotate_joint_state(names, pos, turn)
        if rail:            # the world joint stays put; the rail carries the walk
            names, pos = list(names[:-7]) + ['rail_x'], list(pos[:-7]) + [pos[-7]]
        assert sim.process(stamp, names, pos).accepted
        if k % 30 == 29:
            frames.append(sim_frame(sim, stamp))
    return skeleton, rig, frames


def _check_upright_and_centred(skeleton, frames, axes):
    centre = body_link(skeleton)
    assert skeleton.link_names[centre] == 'base_link'
    head, foot = skeleton.link('head'), skeleton.link('l_foot')
    views = [in_view(f, axes, centre) for f in frames]
    for v in views:
        assert v.links[centre] == pytest.approx(np.zeros(3), abs=1e-12)
        assert v.links[head][2] > 0.6 and v.links[foot][2] < -0.8       # upright: z up
        assert np.abs(v.links[head][:2]).max() < 0.2                      # above the pelvis
        assert np.abs(v.triangles[..., :2]).max() < 0.5                   # the jacket too
    return views


def test_a_walk_away_stays_in_frame_upright_in_any_link_axes():
    urdf = shipped_character_urdf()
    data = load_yaml(shipped('jacket_rig.yaml'))
    inputs = clip_inputs(Skeleton(urdf), 'walk', 3.0)
    skeleton, rig, frames = _frames(urdf, data, inputs)
    # The character walked 4 m through the world: drawn in its root frame it stayed put,
    # drawn in the world without following it, it would have left a 1.4 m wide view.
    travelled = frames[-1].root[:3, 3] - frames[0].root[:3, 3]
    assert travelled[0] > 2.5
    views = _check_upright_and_centred(skeleton, frames, rig.world_axes)
    assert axis_label(rig.world_axes[:, 2], 'up') == 'world +z (m, up)'
    assert axis_label(rig.world_axes[:, 0], 'forward') == 'world +x (m, forward)'
    # The same character with Y-up link frames (and a Y-up world): the same picture.
    turned_urdf = rotate_urdf(urdf, Y_UP)
    turned = rotate_rig(data, Y_UP, root_link(urdf))
    skeleton_t, rig_t, frames_t = _frames(turned_urdf, turned, inputs, Y_UP)
    assert np.abs(frames_t[0].links[skeleton_t.link('head')][1]) > 0.6  # y is up in its frame
    views_t = _check_upright_and_centred(skeleton_t, frames_t, rig_t.world_axes)
    for v, v_t in zip(views, views_t):
        assert v_t.links == pytest.approx(v.links, abs=1e-9)
        assert v_t.triangles == pytest.approx(v.triangles, abs=1e-9)
        assert v_t.hood == pytest.approx(v.hood, abs=1e-9)
    assert axis_label(rig_t.world_axes[:, 2], 'up') == 'world +y (m, up)'


def _turned_half(names, positions):
    """Return a JointState's positions with its world pose turned half a turn about z."""
    out, at = list(positions), {n: k for k, n in enumerate(names)}
    x, y = (at[f'world_joint/trans_{a}'] for a in 'xy')
    out[x], out[y] = -out[x], -out[y]
    q = [at[f'world_joint/rot_{a}'] for a in 'xyzw']
    qx, qy, qz, qw = (positions[k] for k in q)
    for k, v in zip(q, (-qy, qx, qw, -qz)):           # (0, 0, 1, 0) times q
        out[k] = v
    return out


def test_the_front_view_faces_a_character_turned_in_the_world():
    # A character turned about the world's up (a retargeted iCub, a capture facing -x) was
    # drawn from behind under "front view", its side view mirrored (a probe): the views took
    # forward from the URDF, not from where the body faced.
    urdf = shipped_character_urdf()
    data = load_yaml(shipped('jacket_rig.yaml'))
    inputs = [(stamp, names, _turned_half(names, pos)) for stamp, names, pos in
              clip_inputs(Skeleton(urdf), 'walk', 2.0)]
    skeleton, rig, frames = _frames(urdf, data, inputs)
    axes = view_axes_of(frames, rig)
    assert np.allclose(axes, np.diag([-1.0, -1.0, 1.0]), atol=1e-9), axes
    assert axis_label(axes[:, 0], 'forward') == 'world -x (m, forward)'
    centre, left, nose = body_link(skeleton), skeleton.link('l_foot'), skeleton.link('head')
    for v in (in_view(f, axes, centre) for f in frames):
        assert v.links[left][1] > 0.05              # its left foot on the picture's left
        assert v.links[nose][2] > 0.6               # upright
    # Unturned, the views are the rig's as before.
    _, _, straight = _frames(urdf, data, clip_inputs(Skeleton(urdf), 'walk', 1.0))
    assert np.array_equal(view_axes_of(straight, rig), rig.view_axes())


def test_the_side_view_shows_a_body_lying_or_crawling_along_its_length():
    # A crawl's chest faces the floor half turned to a side: the views turned to that side,
    # so the side view saw the body end-on (a review). Now the views follow its head when its
    # own up is tilted over half a right angle; an upright body still faces its front.
    from jacket_cloth_ros.core.transforms import rpy_matrix
    rig = Rig(load_yaml(shipped('jacket_rig.yaml')), Skeleton(shipped_character_urdf()))
    body = rig.world_axes                                   # forward, left, up in the root

    def forward(world):
        """The side view's forward for a body whose forward, left and up are ``world``."""
        axes = rig.view_axes(root_rotation=np.column_stack(world) @ body.T)
        return np.round(axes[:, 0], 9).tolist()
    h = np.sqrt(0.5)
    crawling = ([-h, 0.0, -h], [-h, 0.0, h], [0.0, 1.0, 0.0])     # chest down and to -x
    assert forward(crawling) == [0.0, 1.0, 0.0]                  # where its head lies
    assert forward(([0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0])) == [0.0, 1.0, 0.0]
    c, s = np.cos(0.2), np.sin(0.2)         # on its right side, facing -x, head a little up
    assert forward(([-1.0, 0.0, 0.0], [0.0, -s, c], [0.0, c, s])) == [0.0, 1.0, 0.0]
    assert forward(tuple(rpy_matrix([0.0, 0.0, np.pi / 2]).T)) == [0.0, 1.0, 0.0]  # facing +y
    assert forward(tuple(np.eye(3))) == [1.0, 0.0, 0.0]


def test_a_walk_by_the_urdfs_own_joints_stays_in_frame(tmp_path):
    urdf = shipped_character_urdf().replace('<link name="base_link"/>', RAIL, 1)
    data = load_yaml(shipped('jacket_rig.yaml'))
    data['colliders'] = [c for c in data['colliders'] if c['link'] != 'world']
    inputs = clip_inputs(Skeleton(shipped_character_urdf()), 'walk', 3.0)
    skeleton, rig, frames = _frames(urdf, data, inputs, rail=True)
    assert skeleton.link_names[0] == 'rail'
    assert all(np.array_equal(f.root, np.eye(4)) for f in frames)      # no world joint motion
    assert frames[-1].links[skeleton.link('base_link')][0] > 2.5
    _check_upright_and_centred(skeleton, frames, rig.world_axes)
    png = tmp_path / 'strip.png'
    draw_filmstrip(frames, skeleton, str(png), frames[0].stamp_ns, world_axes=rig.world_axes)
    assert png.stat().st_size > 10_000


def test_the_input_nearest_a_marker_is_found_by_search_as_by_a_scan():
    # Issue 38 item 19: a scan of every input per marker made pictures quadratic in length.
    from jacket_cloth_ros.tools.picture import _nearest
    rng = np.random.default_rng(7)
    stamps = np.sort(rng.integers(0, 10 ** 6, 500))
    stamps[100:110] = stamps[100]                         # a repeated stamp
    for t in list(rng.integers(-10, 10 ** 6 + 10, 2000)) + [int(stamps[100]), -5, 2 * 10 ** 6]:
        k = _nearest(stamps, int(t))
        assert abs(stamps[k] - t) == np.abs(stamps - t).min()
        assert k == int(np.argmin(np.abs(stamps - t)))      # the first of a tie, as min gives
