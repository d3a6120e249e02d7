# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth import``: real BVH captures into a URDF and JointState, as the reader sees them.

The captures are the two real ones bvhtoolbox 0.1.3's source distribution ships (a MocapBank
capture and a free-BVH-archive one); ``make`` fetches them from the registry into the venv's
share/mocap, so nothing here was written by this project.
"""

import json
import os
import shutil

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
from jacket_cloth_ros.core.skeleton import Skeleton, load_skeleton
from jacket_cloth_ros.core.transforms import make_transform, quat_to_matrix
from jacket_cloth_ros.motion.bvh import (Y_UP_TO_Z_UP, continuous_angles, convert, load_capture,
                                         read_bvh)
from jacket_cloth_ros.tools.cli import main
from conftest import one_line_error
from fetched import fetched

CAPTURES = {'test_mocapbank.bvh': (455, 24), 'test_freebvh.bvh': (69, 70)}   # frames, nodes
RIG = os.path.join(os.path.dirname(shipped('character.urdf')), 'examples',
                   'mocapbank_rig.yaml')


@pytest.fixture(scope='module', params=sorted(CAPTURES))
def capture(request):
    path = fetched(request.param)
    bvh, _ = read_bvh(path)
    return request.param, bvh, convert(bvh, request.param.split('.')[0])


def _world_positions(capture, skeleton, frame):
    """Return each BVH node's world position by the URDF's forward kinematics and the root."""
    columns = [capture.joint_names.index(n) for n in skeleton.joint_names]
    links = skeleton.forward(capture.positions[frame, columns])
    root = make_transform(quat_to_matrix(capture.root[frame, 3:]), capture.root[frame, :3])
    rows = [skeleton.link_index[n] for n in capture.link_names]
    return (root @ links[rows])[:, :3, 3]


def test_the_urdf_moves_every_joint_where_the_reader_puts_it(capture):
    name, bvh, cap = capture
    frames, nodes = CAPTURES[name]
    skeleton = Skeleton(cap.urdf)
    assert cap.frames == frames and len(cap.link_names) == nodes == len(bvh.nodes)
    assert sorted(skeleton.joint_names) == sorted(cap.joint_names)
    assert skeleton.root == bvh.nodes[0].name
    assert 1.5 < cap.height_m < 1.9 and cap.scale == 0.01        # centimetres, guessed
    # The reader's own forward kinematics, turned Z-up and into metres once.
    expected = bvh.node_positions() @ Y_UP_TO_Z_UP.T * cap.scale
    worst = max(np.abs(_world_positions(cap, skeleton, k) - expected[k]).max()
                for k in range(cap.frames))
    assert worst < 1e-6
    # The root moves (a capture, not a pose): its path is part of what was compared.
    assert np.ptp(cap.root[:, :3], axis=0).max() > 0.05


def test_rest_link_frames_are_z_up_facing_x():
    cap = load_capture(fetched('test_mocapbank.bvh'))
    skeleton = Skeleton(cap.urdf)
    rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    at = {n: rest[skeleton.link_index[n], :3, 3] for n in ('Head', 'LeftAnkle', 'LeftWrist',
                                                           'LeftAnkle_end')}
    assert at['Head'][2] > 0.5 and at['LeftAnkle'][2] < -0.8        # up is +z
    assert at['LeftWrist'][1] > 0.15                                 # left is +y
    assert at['LeftAnkle_end'][0] - at['LeftAnkle'][0] > 0.1         # the toes point at +x
    assert np.allclose(rest[:, :3, :3], np.eye(3))                   # frames parallel to world
    # One joint a channel, in the file's Euler order (Z, X, Y), about Z-up's axes.
    assert [n for n in skeleton.joint_names if n.startswith('Chest2_')] == [
        'Chest2_Zrotation', 'Chest2_Xrotation', 'Chest2_Yrotation']


def test_a_wrap_at_pi_is_unwrapped_so_interpolation_takes_the_short_way():
    bvh, _ = read_bvh(fetched('test_mocapbank.bvh'))
    raw = bvh.joint_angles
    # The capture itself wraps: LeftHip's first angle goes from 179.99 to -179.96 degrees.
    hip = [n.name for n in bvh.nodes if not n.is_end_site()].index('LeftHip')
    wrap = int(np.argmax(np.abs(np.diff(raw[:, hip, 0]))))
    assert abs(raw[wrap + 1, hip, 0] - raw[wrap, hip, 0]) > 6.0
    cap = convert(bvh, 'mocapbank')
    column = cap.joint_names.index('LeftHip_Zrotation')
    steps = np.abs(np.diff(cap.positions, axis=0))
    assert steps.max() <= np.pi and steps[wrap, column] < 0.01
    # The same rotation each frame: the values moved by whole turns only.
    turns = (cap.positions[:, column] - raw[:, hip, 0]) / (2 * np.pi)
    assert np.allclose(turns, np.round(turns)) and set(np.abs(np.round(turns))) == {0.0, 1.0}
    # A channel made to wrap by hand (2 pi added to a stretch) comes back as it was.
    wrapped = raw.copy()
    wrapped[100:200, 5, 1] += 2 * np.pi
    wrapped[300:, 7, 2] -= 2 * np.pi
    assert np.allclose(continuous_angles(wrapped), continuous_angles(raw))
    # The root quaternion keeps one sign, so no step between samples is a flip to -q.
    q = cap.root[:, 3:]
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert (np.sum(q[1:] * q[:-1], axis=1) > 0.9).all()


def test_import_writes_joint_states_at_the_capture_rate_and_the_urdf(tmp_path, capsys):
    src = fetched('test_freebvh.bvh')
    out, urdf = tmp_path / 'session.mcap', tmp_path / 'char.urdf'
    assert main(['import', src, '-o', str(out), '--urdf-out', str(urdf), '--start', '5']) == 0
    assert '69 JointState messages at 30 Hz' in capsys.readouterr().out
    skeleton = load_skeleton(str(urdf))
    with open(out, 'rb') as f:
        messages = [(m.log_time, msg) for _, _, m, msg in
                    make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                        topics=['/joint_states'])]
    assert len(messages) == 69
    stamps = np.array([t for t, _ in messages])
    assert stamps[0] == 5_000_000_000 and np.allclose(np.diff(stamps), 1e9 / 30, atol=1)
    first = messages[0][1]
    assert first.header.stamp.sec == 5 and first.header.stamp.nanosec == 0
    world = [f'world_joint/{v}' for v in WORLD_VARIABLES]
    assert list(first.name) == sorted(skeleton.joint_names, key=list(first.name).index) + world
    assert set(first.name) == set(skeleton.joint_names) | set(world)
    cap = load_capture(src)
    assert np.allclose(messages[-1][1].position, np.r_[cap.positions[-1], cap.root[-1]])
    # Outputs are checked as the other tools' are: an existing one needs --force.
    assert main(['import', src, '-o', str(out)]) == 1
    assert 'exists (use --force' in capsys.readouterr().err
    # A bag folder too, as motion -o writes one.
    assert main(['import', src, '-o', str(tmp_path / 'bag')]) == 0
    assert (tmp_path / 'bag' / 'metadata.yaml').is_file()


def test_joint_names_with_spaces_are_read_whole_their_words_joined(tmp_path, capsys):
    # The reader cut `JOINT My Spine` at its first space: every joint of such a file was
    # named 'My' and the import refused two parts of one name, a capture of unique names.
    src = fetched('test_freebvh.bvh')
    lines = open(src, encoding='utf-8').read().splitlines()
    spaced = [' '.join(w[:1] + ['My'] + w[1:]) if w[:1] in (['ROOT'], ['JOINT']) else line
              for line, w in ((line, line.split()) for line in lines)]
    path = tmp_path / 'spaced.bvh'
    path.write_text('\n'.join(spaced) + '\n', encoding='utf-8')
    out, urdf = tmp_path / 's.mcap', tmp_path / 's.urdf'
    assert main(['import', str(path), '-o', str(out), '--urdf-out', str(urdf)]) == 0
    err = capsys.readouterr().err
    assert "warning: joint names with spaces, their words joined by _: 'My mixamorig:Hips' " \
        "as 'My_mixamorig:Hips', " in err, err
    plain, joined = load_capture(src), load_capture(str(path))
    assert joined.joint_names == ['My_' + n for n in plain.joint_names]
    assert np.array_equal(joined.positions, plain.positions)
    assert len(joined.renamed) == CAPTURES['test_freebvh.bvh'][1] - sum(
        'End Site' in line for line in lines)
    # Joined, a name may meet another: the refusal says which names were joined.
    clash = [line.replace('JOINT mixamorig:Spine1', 'JOINT mixamorig:Spine_1').replace(
        'JOINT mixamorig:Spine2', 'JOINT mixamorig:Spine 1') for line in lines]
    path.write_text('\r\n'.join(clash) + '\r\n', encoding='utf-8')
    err = one_line_error(capsys, ['import', str(path), '-o', str(tmp_path / 'c.mcap')])
    assert "two parts of the skeleton are both named 'mixamorig:Spine_1" in err and \
        "(joint names with spaces, their words joined by _: 'mixamorig:Spine_1')" in err, err


@pytest.mark.parametrize('content, words', [
    ('', 'empty file'),
    ('just some text\n', 'not a readable BVH file'),
    (None, 'not a readable BVH file'),                     # the capture, cut short
    ('HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition '
     'Zrotation Xrotation Wobble\n}\nMOTION\nFrames: 1\nFrame Time: 0.1\n0 0 0 0 0 0\n',
     'unrecognized channel'),
    # A corrupted angle posed its frame at random; the replay then blamed the rig's shape.
    ('HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition '
     'Zrotation Xrotation Yrotation\n  End Site\n  {\n    OFFSET 0 10 0\n  }\n}\nMOTION\n'
     'Frames: 2\nFrame Time: 0.1\n0 0 0 0 0 0\n0 0 0 0 -1e20 0\n',
     'frame 1: Hips turns -1e+20 deg, beyond the 1e+06 any joint may'),
    # A corrupted root position was imported, and analyze printed figures of 280 digits.
    ('HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition '
     'Zrotation Xrotation Yrotation\n  End Site\n  {\n    OFFSET 0 10 0\n  }\n}\nMOTION\n'
     'Frames: 2\nFrame Time: 0.1\n0 0 0 0 0 0\n1e300 0 0 0 0 0\n',
     "the root is 5.64e+298 m from the origin, beyond the 1e+06 m a capture's root may "
     'reach (a corrupted frame?)'),
    # The reader turned a NaN frame time into an integer and said only that.
    ('HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition '
     'Zrotation Xrotation Yrotation\n  End Site\n  {\n    OFFSET 0 10 0\n  }\n}\nMOTION\n'
     'Frames: 1\nFrame Time: nan\n0 0 0 0 0 0\n',
     'Frame Time nan is outside [0.0001, 1] s'),
])
def test_a_bad_file_is_one_line_and_exit_1(tmp_path, capsys, content, words):
    bad = tmp_path / 'bad.bvh'
    if content is None:
        with open(fetched('test_mocapbank.bvh'), encoding='utf-8') as f:
            content = f.read()[:20_000]
    bad.write_text(content)
    out = tmp_path / 'out.mcap'
    assert main(['import', str(bad), '-o', str(out), '--urdf-out', str(tmp_path / 'c.urdf')]) \
        == 1
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and err.startswith('jacket_cloth import: ') and words in err
    assert not out.exists() and not (tmp_path / 'c.urdf').exists()


def test_a_hierarchy_missing_a_brace_is_refused_not_read_as_another_skeleton(tmp_path, capsys):
    # pybvh read a HIERARCHY with a '}' missing as a different skeleton (1.74 m tall where the
    # capture is 1.67 m) and the import wrote it (a hostile probe).
    with open(fetched('test_mocapbank.bvh'), encoding='utf-8') as f:
        text = f.read()
    head, motion = text.split('MOTION', 1)
    cut = head.rindex('}', 0, head.rindex('}'))          # a brace inside, not the last
    bad = tmp_path / 'bad.bvh'
    bad.write_text(head[:cut] + head[cut + 1:] + 'MOTION' + motion)
    out = tmp_path / 'out.mcap'
    assert main(['import', str(bad), '-o', str(out), '--urdf-out', str(tmp_path / 'c.urdf')]) \
        == 1
    err = capsys.readouterr().err
    assert err == f'jacket_cloth import: {bad}: its HIERARCHY opens 24 braces and closes 23\n'
    assert not out.exists() and not (tmp_path / 'c.urdf').exists()


def test_a_mocap_session_replays_with_the_jacket_fitted_to_its_skeleton(tmp_path):
    src = str(tmp_path / 'mocapbank.bvh')
    shutil.copy(fetched('test_mocapbank.bvh'), src)
    session, urdf = tmp_path / 'mocap.mcap', tmp_path / 'mocapbank.urdf'
    assert main(['import', src, '-o', str(session), '--urdf-out', str(urdf)]) == 0
    jacket, again = tmp_path / 'jacket.mcap', tmp_path / 'again.mcap'
    assert main(['replay', str(session), '-o', str(jacket), '--urdf', str(urdf),
                 '--rig', RIG]) == 0
    # The replay carries its set-up: a replay of it needs no option and gives the same bones.
    assert main(['replay', str(jacket), '-o', str(again)]) == 0
    assert main(['analyze', str(jacket), str(again), '--compare', '--moments', '2',
                 '--out', str(tmp_path / 'analysis')]) == 0
    first, second = json.loads((tmp_path / 'analysis' / 'report.json').read_text())['sessions']
    for report in (first, second):
        assert report['inputs'] == report['frames'] == 455 and report['dropped_inputs'] == 0
        assert report['nonfinite_count'] == 0
        assert report['reset_reasons'] == ['first sample']
        assert 0.0 < report['max_vertical_strain'] < 0.5
        assert report['sim_steps'] >= 454 * 2
    assert second['replay_matches_recording'] is True and second['recorded_tf_compared'] == 455


def _in_unit(text: str, factor: float) -> str:
    """Return a BVH text whose lengths (OFFSETs, the root's positions) are times ``factor``."""
    lines, frames = [], False
    for line in text.splitlines():
        words = line.split()
        if words[:1] == ['OFFSET']:
            line = 'OFFSET ' + ' '.join(f'{float(v) * factor:.6f}' for v in words[1:])
        elif frames and words:
            line = ' '.join([f'{float(v) * factor:.6f}' for v in words[:3]] + words[3:])
        frames = frames or line.startswith('Frame Time')
        lines.append(line)
    return '\n'.join(lines) + '\n'


def test_a_cmu_capture_is_guessed_in_its_unit_and_a_wrong_unit_is_said(tmp_path, capsys):
    # Issue 35 item 6: CMU's 3ds Max conversion (in / 0.45) imported as a 0.62 m person.
    path = fetched('test_mocapbank.bvh')
    in_cm = load_capture(path)
    with open(path, encoding='utf-8') as f:
        text = f.read()
    cmu = tmp_path / 'cmu.bvh'
    cmu.write_text(_in_unit(text, 0.01 / (0.0254 / 0.45)))
    got = load_capture(str(cmu))
    assert got.scale == 0.0254 / 0.45
    assert abs(got.height_m - in_cm.height_m) < 1e-4
    # A unit given wrong is imported as asked, with one line saying so.
    assert main(['import', path, '-o', str(tmp_path / 'mm.mcap'), '--scale', '0.001']) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'tall at 0.001 m per unit' in err[0] and '--scale' in err[0], err
    assert main(['import', str(cmu), '-o', str(tmp_path / 'cmu.mcap')]) == 0
    assert capsys.readouterr().err == ''


def test_a_capture_exported_z_up_is_said_to_be_so_not_given_another_unit(tmp_path, capsys):
    # A z-up export was said to be 0.20 m tall with the advice to give its unit, which mends
    # nothing (a hostile probe), and its unit was guessed from its depth (a review); the real
    # captures, y-up, get no line.
    path = fetched('test_mocapbank.bvh')
    with open(path, encoding='utf-8') as f:
        lines = f.read().splitlines()
    for k, line in enumerate(lines):        # each OFFSET's y and z swapped, the motion kept
        if line.strip().startswith('OFFSET'):
            head, x, y, z = line.rsplit(maxsplit=3)
            lines[k] = f'{head} {x} {z} {y}'
    zup = tmp_path / 'zup.bvh'
    zup.write_text('\n'.join(lines) + '\n')
    assert main(['import', str(zup), '-o', str(tmp_path / 'zup.mcap')]) == 0
    said = capsys.readouterr()
    err = said.err.strip().splitlines()
    assert len(err) == 1 and 'spans most along z, not y' in err[0], err
    assert 'scale 0.01 m per unit' in said.out, said.out      # its unit, from its z span
    assert 'export the capture y-up' in err[0] and '--scale' not in err[0], err
    for real in ('test_mocapbank.bvh', 'test_freebvh.bvh'):
        assert main(['import', fetched(real), '-o', str(tmp_path / f'{real}.mcap')]) == 0
        assert capsys.readouterr().err == ''


UPPER_BODY = '''HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 50 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 0 15 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 14 0
      }
    }
    JOINT LeftArm
    {
      OFFSET 20 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 70 0 0
      }
    }
    JOINT RightArm
    {
      OFFSET -20 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET -70 0 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.033333
0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
0 90 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
'''


def test_an_upper_body_capture_is_guessed_in_its_unit_by_its_arm_span(tmp_path, capsys):
    # A capture of the upper body alone, 79 cm tall, was imported in inches as a 2 m person
    # with no word (a hostile probe): its arms span a person's height, 1.8 m in centimetres.
    path = tmp_path / 'upper.bvh'
    path.write_text(UPPER_BODY)
    assert main(['import', str(path), '-o', str(tmp_path / 'upper.mcap')]) == 0
    said = capsys.readouterr()
    assert 'scale 0.01 m per unit, 0.79 m tall' in said.out and said.err == '', said
