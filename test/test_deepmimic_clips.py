# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""DeepMimic's motion clips on pybullet's DeepMimic humanoid: import, and issue 19's targets.

``make`` fetches the 15 humanoid clips of pybullet 3.2.7's ``pybullet_data/data/motions``
(zlib, see docs/motion_capture.md) with ``humanoid.urdf`` into share/mocap; none is
committed. Each goes through ``jacket_cloth import CLIP --urdf humanoid.urdf``, then the
replay's pipeline at the default settings with the rig ``jacket_cloth rig`` proposes for the
humanoid, measured after every input as ``jacket_cloth analyze`` measures it
(core.measures), as test_mocap_targets.py does for the BVH captures. Whole clips: 25 to 227 inputs.
"""

import math

import numpy as np
import pytest

from jacket_cloth_ros.core.skeleton import load_skeleton
from jacket_cloth_ros.core.transforms import quat_to_matrix
from jacket_cloth_ros.motion.deepmimic import (LAYOUT, continuous_zxy, convert, load_clip,
                                               read_frames, zxy_angles)
from jacket_cloth_ros.tools.cli import main
from jacket_cloth_ros.tools.session import load_session
from fetched import fetched
from per_input import measure_every_input

# Per clip: its inputs. Every humanoid clip of the data set (issue 47: all of them).
CLIPS = {'walk': 39, 'run': 25, 'jump': 107, 'cartwheel': 164, 'dance_a': 98, 'spinkick': 78,
         'backflip': 29, 'crawl': 177, 'dance_b': 153, 'getup_facedown': 183,
         'getup_faceup': 227, 'kick': 47, 'punch': 65, 'roll': 122, 'spin': 107}
# The backflip's flip is faster than one 120 Hz step resolves: its horizontal stretch p99 was
# 10.1 % (max 10.6 %) until a step that overstretches a row ran again in finer substeps. The
# crawl and the get-up from face up put the hem 71 and 143 mm into a foot until the proposed
# rig took the feet's shapes too.


def _clip(name):
    return fetched(f'humanoid3d_{name}.txt')


def _rot(axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _zxy(a, b, c):
    return _rot(2, a) @ _rot(0, b) @ _rot(1, c)


def test_zxy_angles_give_back_the_rotation_also_at_gimbal_lock():
    rng = np.random.default_rng(7)
    angles = rng.uniform(-3, 3, (200, 3))
    angles[:, 1] = rng.uniform(-1.5, 1.5, 200)
    for a, b, c in angles:
        r = _zxy(a, b, c)
        assert np.allclose(_zxy(*zxy_angles(r)), r, atol=1e-12)
        assert np.allclose(zxy_angles(r), [a, b, c], atol=1e-9)
    for b in (math.pi / 2, -math.pi / 2):           # only a + c (a - c) is defined there
        r = _zxy(0.4, b, 0.3)
        assert np.allclose(_zxy(*zxy_angles(r)), r, atol=1e-12)


def test_angles_follow_the_motion_through_the_lock_not_the_short_branch():
    # A shoulder raised sideways through b = pi/2 (x, to 100 degrees): atan2 alone keeps b
    # within +-90 and turns a and c by pi in one frame; the import keeps every angle close.
    b = np.radians(np.linspace(60, 100, 41))
    rots = np.array([_zxy(0.2, v, -0.1) for v in b])
    out = continuous_zxy(zxy_angles(rots))
    assert np.abs(np.diff(out, axis=0)).max() < 0.02
    assert np.allclose(out[-1], [0.2, b[-1], -0.1], atol=1e-6)
    for r, v in zip(rots, out):
        assert np.allclose(_zxy(*v), r, atol=1e-9)


# The roll's frames last 0.016666 and 0.032666 s: resampled at its rate, its frame k is not the
# file's (test_uneven_frames_are_resampled_at_the_clips_rate holds the resampling).
UNEVEN = ('roll',)


def test_only_the_roll_has_uneven_frames():
    uneven = {name for name in CLIPS if np.ptp(read_frames(_clip(name))[:-1, 0]) > 1e-6}
    assert uneven == set(UNEVEN)


@pytest.mark.parametrize('name', sorted(set(CLIPS) - set(UNEVEN)))
def test_forward_kinematics_of_the_imported_joints_is_the_clips_pose(name):
    # Every ball joint: the rotation from its parent link to its link, through the three
    # continuous joints, is the clip's quaternion (w, x, y, z); knees and elbows its angle.
    urdf = fetched('humanoid.urdf')
    sk = load_skeleton(urdf)
    frames = read_frames(_clip(name))
    cap = load_clip(_clip(name), urdf)
    assert cap.frames == len(frames) == CLIPS[name]
    assert cap.frame_time == pytest.approx(frames[0, 0], abs=1e-9)
    columns = [sk.joint_index[j] for j in cap.joint_names]
    worst = 0.0
    for k in range(cap.frames):
        q = np.zeros(len(sk.joint_names))
        q[columns] = cap.positions[k]
        links = sk.forward(q)
        i = 8
        for joint, n in LAYOUT:
            child = sk.link(joint)
            # A ball joint's chain starts at its first massless link's parent.
            parent = sk.parent[sk.link(f'{joint}_Zrotation_link')] if n == 4 else \
                sk.parent[child]
            turn = (np.linalg.inv(links[parent]) @ links[child])[:3, :3]
            if n == 4:
                w, x, y, z = frames[k, i:i + 4]
                want = quat_to_matrix([x, y, z, w])
            else:
                want = _rot(2, frames[k, i])
            worst = max(worst, float(np.abs(turn - want).max()))
            i += n
    assert worst < 1e-9
    # The root: the URDF root link's pose, positions four times the clip's (pybullet loads
    # the humanoid at a quarter), both turned from the clip's Y-up world into REP 103's Z-up
    # one (x, y, z) -> (x, -z, y); the rotation as x, y, z, w, up to its sign.
    x, y, z = (frames[:, 1 + i] * 4.0 for i in range(3))
    assert np.allclose(cap.root[:, :3], np.column_stack([x, -z, y]))
    y_up = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    for k in range(cap.frames):
        w, qx, qy, qz = frames[k, 4:8] / np.linalg.norm(frames[k, 4:8])
        assert np.allclose(quat_to_matrix(cap.root[k, 3:]), y_up @ quat_to_matrix([qx, qy, qz, w]))


def test_the_walking_humanoid_stands_on_the_z_up_floor():
    # Scale and up checked together: the standing foot's ankle is its box's half height plus
    # the box's offset (0.11 + 0.09 m) above z = 0 at its lowest, within 5 cm: the clip's Y-up
    # world is REP 103's Z-up one (issue 47 item 1), the humanoid standing in it.
    urdf = fetched('humanoid.urdf')
    sk = load_skeleton(urdf)
    cap = load_clip(_clip('walk'), urdf)
    columns = [sk.joint_index[j] for j in cap.joint_names]
    lowest = []
    for k in range(cap.frames):
        q = np.zeros(len(sk.joint_names))
        q[columns] = cap.positions[k]
        links = sk.forward(q)
        turn = quat_to_matrix(cap.root[k, 3:])
        lowest.append(min((turn @ links[sk.link(f'{s}_ankle')][:3, 3] + cap.root[k, :3])[2]
                          for s in ('left', 'right')))
    assert abs(min(lowest) - 0.20) < 0.05


def test_uneven_frames_are_resampled_at_the_clips_rate():
    frames = read_frames(_clip('walk'))
    # Frames 10 to 20 kept at every other one, each lasting two frames: 34 frames, 1.27 s.
    keep = [k for k in range(len(frames)) if not (10 < k < 20 and k % 2)]
    uneven = frames[keep].copy()
    for j, k in enumerate(keep[:-1]):
        uneven[j, 0] = frames[k:keep[j + 1], 0].sum()
    text = open(fetched('humanoid.urdf'), encoding='utf-8').read()
    cap, even = convert(uneven, 'uneven', text), convert(frames, 'walk', text)
    assert cap.frame_time == pytest.approx(frames[0, 0]) and cap.frames == len(frames)
    # The kept frames come out as they are; the dropped ones halfway between their neighbours.
    assert np.allclose(cap.positions[keep], even.positions[keep], atol=1e-9)
    knee, dropped = cap.joint_names.index('right_knee'), np.arange(11, 20, 2)
    for values in (cap.positions[:, knee], cap.root[:, :3]):
        assert np.allclose(values[dropped], (values[dropped - 1] + values[dropped + 1]) / 2)
    assert not np.allclose(cap.positions[dropped], even.positions[dropped])


def test_a_resampled_clip_ends_at_its_last_frame():
    # The roll lasts 2.016 s in frames of 16.7 ms and 16 ms: resampled at the usual frame
    # time it ended 16 ms short, its last pose never reached (a review).
    from jacket_cloth_ros.motion.deepmimic import _quaternion_columns, _resample, frame_time
    frames = read_frames(_clip('roll'))
    times = np.cumsum(np.r_[0.0, frames[:-1, 0]])
    dt = frame_time(frames[:, 0])
    out = _resample(frames, dt)
    assert len(out) == 122
    linear = np.ones(frames.shape[1], dtype=bool)     # the quaternions come out unit
    for i, _ in _quaternion_columns():
        linear[i:i + 4] = False
        q = frames[-1, i:i + 4]
        assert np.allclose(out[-1, i:i + 4], q / np.linalg.norm(q), atol=1e-9)
    linear[0] = False
    assert np.allclose(out[-1, linear], frames[-1, linear], atol=1e-12)
    # So does one whose last frame is short of a whole frame time: its last pose kept.
    short = frames.copy()
    short[-2, 0] = 0.3 * dt
    assert np.allclose(_resample(short, dt)[-1, linear], short[-1, linear], atol=1e-12)
    # Before it, every usual frame time; the root's height linear between the clip's frames.
    at = np.arange(len(out) - 1) * dt
    assert np.allclose(out[:-1, 2], np.interp(at, times, frames[:, 2]), atol=1e-12)


@pytest.mark.parametrize('content, words', [
    ('just some text\n', 'not a DeepMimic clip (not JSON'),
    ('{"Loop": "wrap"}', 'no "Frames" list'),
    ('{"Frames": [[0.1, 0, 1]]}', 'frame 0 is not 44 numbers'),
    ('{"Frames": [[' + ', '.join(['NaN'] + ['0'] * 43) + ']]}', 'not a finite number'),
    ('{"Frames": [[' + ', '.join(['0'] * 44) + ']]}', 'frames last 0 s'),
    ('{"Frames": [[' + ', '.join(['-0.1'] + ['0'] * 43) + ']]}', 'frame 0 lasts less than 0 s'),
    ('{"Frames": [[' + ', '.join(['0.1'] + ['0'] * 43) + ']]}', 'a quaternion is zero'),
])
def test_a_malformed_clip_is_one_line_and_exit_1(tmp_path, capsys, content, words):
    bad, out = tmp_path / 'bad.txt', tmp_path / 'out.mcap'
    bad.write_text(content)
    assert main(['import', str(bad), '--urdf', fetched('humanoid.urdf'), '-o', str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith('jacket_cloth import: ') and words in err
    assert not out.exists()


def test_a_clip_needs_the_humanoid_it_moves(tmp_path, capsys):
    out = tmp_path / 'out.mcap'
    assert main(['import', _clip('walk'), '-o', str(out)]) == 1            # no --urdf
    assert 'needs --urdf' in capsys.readouterr().err
    from jacket_cloth_ros.core.config import shipped
    assert main(['import', _clip('walk'), '--urdf', shipped('character.urdf'),
                 '-o', str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and "has no joint 'chest_Zrotation'" in err
    assert main(['import', _clip('walk'), '--urdf', fetched('humanoid.urdf'), '-o', str(out),
                 '--urdf-out', str(tmp_path / 'x.urdf')]) == 1
    assert '--urdf-out is for a BVH capture' in capsys.readouterr().err
    assert not out.exists()


@pytest.fixture(scope='module')
def rig(tmp_path_factory):
    """The rig ``jacket_cloth rig`` proposes for the humanoid (as test_public_humanoid's)."""
    path = tmp_path_factory.mktemp('rig') / 'rig.yaml'
    assert main(['rig', '--urdf', fetched('humanoid.urdf'), '-o', str(path)]) == 0
    return str(path)


@pytest.fixture(scope='module', params=sorted(CLIPS))
def measured(request, rig, tmp_path_factory):
    """Import, replay at the default settings, and measure one clip after every input."""
    name, urdf = request.param, fetched('humanoid.urdf')
    session = tmp_path_factory.mktemp('clip') / f'{name}.mcap'
    assert main(['import', _clip(name), '--urdf', urdf, '-o', str(session)]) == 0
    loaded = load_session(str(session), urdf=urdf, rig=rig)
    series = measure_every_input(loaded)
    return name, series


def test_every_input_of_a_clip_holds_the_jacket_unstretched_and_outside(measured):
    # Issue 19 item 3 at the default settings, as test_mocap_targets.py asserts it: no
    # vertical edge over 10 % (p99 3 %), never over 1 cm inside a collider (p99 3 mm), no
    # reset but the first sample's (none of these clips teleports).
    name, s = measured
    assert s['published'] == s['inputs'] == len(s['vertical_stretch']) == CLIPS[name]
    assert s['resets'] == ['first sample']
    stretch, inside = np.array(s['vertical_stretch']), np.array(s['inside_m'])
    assert np.percentile(stretch, 99) <= 0.03, name
    assert inside.max() <= 0.01 and np.percentile(inside, 99) <= 0.003, name
    # M8 on the floor: getting up from lying on the back, the hood hung up to 49 cm through it
    # at 97 of the 227 inputs before it rested on the rig's planes.
    assert s['hood_under_plane_m'].max() <= 1e-9, name
    # The jacket a viewer sees, skinned between the particles on the floor, reached 112 to
    # 269 mm under it crawling, rolling and getting up; the markers hold it on the rig's planes.
    assert s['drawn_under_floor_m'].max() <= 1e-9, name
    # Issue 35: the same inside the body proxy (the humanoid's every shape). Before the knees'
    # shapes were colliders, the spinkick's hem was 92 mm inside the kicking shin (about 23 mm
    # at a person's size).
    body = s['body_inside_m']
    assert body.max() <= 0.01 and np.percentile(body, 99) <= 0.003, name


@pytest.mark.parametrize('name', sorted(CLIPS))
def test_a_clip_lying_or_crawling_is_drawn_along_its_length(name, rig, tmp_path):
    # The crawl's side view saw the body end-on: its chest faces the floor half turned to a
    # side, and the views followed the chest (0.34 of the body along the page). Each clip's
    # pictures face the view its first frame sets: a body lying lies along the side view.
    from jacket_cloth_ros.core.fabric import load_fabric
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.simulation import JacketSimulation
    from jacket_cloth_ros.recording.reader import read_recording
    from jacket_cloth_ros.ros.cdr import JointStateReader
    urdf, session = fetched('humanoid.urdf'), tmp_path / 'clip.mcap'
    assert main(['import', _clip(name), '--urdf', urdf, '-o', str(session)]) == 0
    skeleton = load_skeleton(urdf)
    proposed = load_rig(skeleton, rig)
    sim = JacketSimulation(skeleton, proposed, load_fabric('tweed_jacket'))
    first = JointStateReader().read(next(iter(read_recording(
        str(session), topics=('/joint_states',)).messages)).data)
    assert sim.process(first.stamp_ns, first.name, first.position).accepted
    axes = proposed.view_axes(root_rotation=sim.root[:3, :3])
    spine = sim.root[:3, :3] @ (sim.links[skeleton.link('neck'), :3, 3] - sim.links[0, :3, 3])
    across = spine - (spine @ axes[:, 2]) * axes[:, 2]
    if np.linalg.norm(across) > 0.5 * np.linalg.norm(spine):         # lying, or crawling
        assert abs(across @ axes[:, 0]) > 0.7 * np.linalg.norm(across), name


def test_the_live_markers_hold_the_jacket_on_the_floor(rig, tmp_path):
    # The node's and the replay's MarkerArray bytes (marker_array), as the pictures' jacket
    # (marker_specs, measured for every clip above): getting up from face down, the jacket
    # reached 0.17 m under the floor.
    from rclpy.serialization import deserialize_message
    from visualization_msgs.msg import MarkerArray
    from jacket_cloth_ros.core.measures import depth_under_floor
    from jacket_cloth_ros.tools.session import run_session
    urdf, session = fetched('humanoid.urdf'), tmp_path / 'getup.mcap'
    assert main(['import', _clip('getup_facedown'), '--urdf', urdf, '-o', str(session)]) == 0
    loaded = load_session(str(session), urdf=urdf, rig=rig)
    floor = loaded.setup.rig.floor()
    under = []

    def probe(pipeline, report, stamp, outputs):
        for key, data in outputs:
            if key == 'markers':
                [jacket] = [m for m in deserialize_message(data, MarkerArray).markers
                            if m.ns == 'jacket' and m.points]
                points = np.array([[p.x, p.y, p.z] for p in jacket.points])
                under.append(depth_under_floor(points, pipeline.sim.root, floor))
    run_session(loaded, probe=probe)
    assert len(under) > 80 and max(under) <= 1e-9, (len(under), max(under))


def test_no_vertical_edge_of_a_clip_stretches_over_10_percent(measured):
    # The cartwheel's 11.3 % at one input went with the horizontal strain limit in M12.
    name, s = measured
    assert max(s['vertical_stretch']) <= 0.10, name


def test_horizontal_stretch_of_a_clip_is_within_the_target(measured):
    # Issue 19's 10 % at p99. The cartwheel, where a row wraps a thigh raised sideways, met
    # it once the row's limit and verticals ran until they agree (19.0 % at 5 rounds). The
    # backflip once a step that overstretches a row runs again in twice the substeps (10.6 %
    # at its worst input before; more sweeps do not hold it, the row limit then fighting a
    # cloth further from its pose). No input of any clip is over 10 % now.
    name, s = measured
    assert np.percentile(s['horizontal_stretch'], 99) <= 0.10, name
    assert s['horizontal_stretch'].max() <= 0.10, name
