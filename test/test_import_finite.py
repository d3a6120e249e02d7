# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Import and play never pass on a value that is not a finite number, nor a text as a URDF.

A hostile probe's findings: a DeepMimic clip or a BVH capture whose values overflow once
scaled or normalised was written with NaN or inf and exit 0; a huge JSON integer or deeply
nested arrays ended in a traceback; ``play`` published NaN positions, and any text given
with ``--urdf`` as robot_description. Each is now one line, exit 1, and no output file.
"""

import json
import warnings

import pytest

from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
from jacket_cloth_ros.ros.cdr import joint_state
from jacket_cloth_ros.tools import cli
from jacket_cloth_ros.tools.cli import main
from conftest import one_line_error
from fetched import fetched


@pytest.fixture(autouse=True)
def numpy_warnings_fail():
    """Turn a RuntimeWarning (numpy's overflow or invalid value) into a failure.

    Such a warning is a second line on stderr, beside the tool's own one.
    """
    with warnings.catch_warnings():
        warnings.simplefilter('error', RuntimeWarning)
        yield


def _walk_frames():
    with open(fetched('humanoid3d_walk.txt'), encoding='utf-8') as f:
        return json.load(f)


def _import_clip(capsys, tmp_path, text):
    """Import the clip ``text``; return its one error line, the output checked absent."""
    clip, out = tmp_path / 'clip.txt', tmp_path / 'out.mcap'
    clip.write_text(text)
    err = one_line_error(capsys, ['import', str(clip), '--urdf', fetched('humanoid.urdf'),
                                  '-o', str(out)])
    assert err.startswith(f'jacket_cloth import: {clip}: '), err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ['clip.txt']
    return err


def test_a_clip_quaternion_too_long_to_normalise_is_refused_by_frame_and_joint(
        tmp_path, capsys):
    clip = _walk_frames()
    clip['Frames'][3][8:12] = [1e300, 1e300, 0, 0]          # the chest's, w x y z
    err = _import_clip(capsys, tmp_path, json.dumps(clip))
    assert 'frame 3: a quaternion is too long to normalise' in err and 'joint chest' in err


def test_a_clip_root_position_that_overflows_when_scaled_is_refused_by_frame(tmp_path, capsys):
    clip = _walk_frames()
    clip['Frames'][2][1] = 1e308                # finite in the file, inf times the scale
    err = _import_clip(capsys, tmp_path, json.dumps(clip))
    assert "frame 2: the root's x position is inf after scaling" in err
    assert 'not a finite number (root positions times 4)' in err


def test_a_bvh_root_position_that_overflows_when_scaled_is_refused_by_frame(tmp_path, capsys):
    # Short bones, so the skeleton fits at a million metres per unit; the root's position
    # channel does not.
    bvh, out = tmp_path / 'big.bvh', tmp_path / 'out.mcap'
    bvh.write_text('HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition '
                   'Zposition Zrotation Yrotation Xrotation\n\tJOINT Spine\n\t{\n\t\tOFFSET 0 '
                   '0.0001 0\n\t\tCHANNELS 3 Zrotation Yrotation Xrotation\n\t\tEnd Site\n\t\t'
                   '{\n\t\t\tOFFSET 0 0.0001 0\n\t\t}\n\t}\n}\nMOTION\nFrames: 2\n'
                   'Frame Time: 0.0333333\n0 0 0 0 0 0 0 0 0\n1e303 0 0 0 0 0 0 0 0\n')
    err = one_line_error(capsys, ['import', str(bvh), '--scale', '1e6', '-o', str(out)])
    assert err == (f"jacket_cloth import: {bvh}: frame 1: the root's y position is inf after "
                   'scaling and normalising, not a finite number (at 1e+06 m per unit)')
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ['big.bvh']


@pytest.mark.parametrize('digits, words', [
    (400, 'frame 1 holds an integer too large for a number'),
    (5000, 'Exceeds the limit'),            # longer than Python reads as an integer
])
def test_a_clip_integer_too_large_for_a_float_is_one_line(tmp_path, capsys, digits, words):
    clip = _walk_frames()
    clip['Frames'][1][1] = 12345.5          # a mark to put the integer in place of
    text = json.dumps(clip)
    at = text.index('12345.5')
    err = _import_clip(capsys, tmp_path, text[:at] + '1' + '0' * digits + text[at + 7:])
    assert words in err and 'set_int_max_str_digits' not in err


def test_a_clip_nested_too_deep_is_one_line(tmp_path, capsys):
    err = _import_clip(capsys, tmp_path, '{"Frames": ' + '[' * 100_000 + ']' * 100_000 + '}')
    assert err.endswith('not a DeepMimic clip (its JSON nests too deep)')


def _recording(path, positions):
    """Write JointStates of two joints, one message per row of ``positions``."""
    rec = SessionRecorder(str(path))
    rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    for k, row in enumerate(positions):
        stamp = 1_000_000_000 + k * 10_000_000
        rec.write('/joint_states', joint_state(stamp, ['a', 'b'], list(row)), stamp)
    rec.close()
    return path


@pytest.fixture
def published(monkeypatch):
    """What play hands to the ROS graph: (URDF, [(offset, names, positions), ...]) per call."""
    calls = []

    def play_live(name, urdf, inputs, *args, **kwargs):
        calls.append((urdf, list(inputs)))
        return len(calls[-1][1])
    monkeypatch.setattr(cli, 'play_live', play_live)
    return calls


def test_play_hands_a_finite_recording_over_whole(tmp_path, capsys, published):
    # The control for the refusals below: the same recording, finite, is played.
    path = _recording(tmp_path / 'ok.mcap', [[0.0, 1.0], [0.5, 1.5], [1.0, 2.0]])
    assert main(['play', str(path), '--urdf', fetched('humanoid.urdf'), '--wait', '0']) == 0
    assert len(published) == 1 and len(published[0][1]) == 3
    with open(fetched('humanoid.urdf'), encoding='utf-8') as f:
        assert published[0][0] == f.read()


@pytest.mark.parametrize('bad', [float('nan'), float('inf')])
def test_play_refuses_a_position_that_is_not_finite_before_publishing(
        tmp_path, capsys, published, bad):
    path = _recording(tmp_path / 'nan.mcap', [[0.0, 1.0], [0.5, bad], [1.0, 2.0]])
    err = one_line_error(capsys, ['play', str(path), '--urdf', fetched('humanoid.urdf'),
                                  '--wait', '0'])
    assert err == (f'jacket_cloth play: {path}: a /joint_states message logged at 1010000000 '
                   f'ns gives b {bad}, not a finite number: nothing was published')
    assert published == []


CYCLIC = ('<robot name="r"><link name="a"/><link name="b"/>'
          '<joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>'
          '<joint name="j2" type="fixed"><parent link="b"/><child link="a"/></joint></robot>')


@pytest.mark.parametrize('text', ['just some text, no XML\n', CYCLIC])
def test_play_refuses_a_urdf_as_motion_does(tmp_path, capsys, published, text):
    path = _recording(tmp_path / 'ok.mcap', [[0.0, 1.0], [0.5, 1.5]])
    urdf = tmp_path / 'bad.urdf'
    urdf.write_text(text)
    err = one_line_error(capsys, ['play', str(path), '--urdf', str(urdf), '--wait', '0'])
    assert published == []
    said = one_line_error(capsys, ['motion', '--urdf', str(urdf), '--wait', '0'])
    assert err.removeprefix('jacket_cloth play: ') == said.removeprefix('jacket_cloth motion: ')
    assert str(urdf) in err


def test_play_refuses_a_recorded_urdf_no_tool_would_load(tmp_path, capsys, published):
    # Only a URDF given with --urdf was checked: a recording's own went out as
    # robot_description whatever it held (the fix's own report).
    from jacket_cloth_ros.recording.writer import SESSION_CONFIG
    path = tmp_path / 'cyclic.mcap'
    rec = SessionRecorder(str(path))
    rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    rec.add_metadata(SESSION_CONFIG, {'urdf': CYCLIC})
    rec.write('/joint_states', joint_state(10 ** 9, ['a', 'b'], [0.0, 1.0]), 10 ** 9)
    rec.close()
    err = one_line_error(capsys, ['play', str(path), '--wait', '0'])
    assert err.startswith(f'jacket_cloth play: {path}: its recorded URDF: malformed robot '
                          'description'), err
    assert published == []
