# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Hostile files and options for the tools (issue 38): one line, non-zero, bounded work.

Bounds are shown by the check firing (a claim refused before the work it asks for) and by
counts of bytes read or allocated, never by elapsed time.
"""

import io
import os
import struct
import tracemalloc

import pytest
import zstandard
from conftest import one_line_error, signalled

from jacket_cloth_ros.recording.mcap_file import McapWriter
from jacket_cloth_ros.recording.reader import (
    MAGIC, MAX_CHUNK_BYTES, RecordingError, read_recording)
from jacket_cloth_ros.tools.cli import main


@pytest.fixture(scope='module')
def clip(tmp_path_factory):
    """An input-only session: 1 s of the walk clip at 60 Hz, as the motion tool writes it."""
    path = tmp_path_factory.mktemp('clip') / 'clip.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '1.0', '-o', str(path)]) == 0
    return path


def _one_chunk(compression='zstd'):
    """A finished MCAP of one chunk of three messages; (bytes, the chunk's offset)."""
    out = io.BytesIO()
    w = McapWriter(out, compression=compression)
    w.start(profile='ros2', library='test')
    schema = w.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
    channel = w.register_channel('/t', 'cdr', schema)
    for i in range(3):
        w.add_message(channel, 1000 + i, bytes([i]) * 50, 1000 + i)
    w.finish()
    data = out.getvalue()
    return data, data.index(b'\x06', data.index(b'/t'))


def _chunk_with(data, at, declared, packed):
    """``data`` with the chunk at ``at`` declaring ``declared`` bytes and holding ``packed``
    (its CRC zeroed: only the sizes are on trial)."""
    head = struct.unpack_from('<BQQQQI', data, at)
    name = b'zstd'
    body = (struct.pack('<QQQI', head[2], head[3], declared, 0) + struct.pack('<I', len(name))
            + name + struct.pack('<Q', len(packed)) + packed)
    old_length = head[1]
    # A cut after the chunk: its summary and footer no longer match the offsets, which is not
    # the trial here; a cut file is read up to where it ends.
    return data[:at] + struct.pack('<BQ', 0x06, len(body)) + body, at + 9 + old_length


def test_a_chunk_claiming_more_than_the_cap_is_refused_before_decompressing(tmp_path):
    data, at = _one_chunk()
    path = tmp_path / 'big.mcap'
    packed = zstandard.ZstdCompressor().compress(b'\x00' * 100)
    bad, _ = _chunk_with(data, at, 3 << 30, packed)
    path.write_bytes(bad)
    with pytest.raises(RecordingError, match=f'says it holds {3 << 30} bytes decompressed, '
                       f'over the {MAX_CHUNK_BYTES}'):
        read_recording(str(path))


def test_a_chunk_that_decompresses_beyond_its_declared_size_is_refused_within_it(tmp_path):
    # The frame says 64 MB (as the 107 KB file of issue 38 said 3 GB); the chunk says 1000.
    frame = io.BytesIO()
    compressor = zstandard.ZstdCompressor(write_content_size=True)
    writer = compressor.stream_writer(frame, size=64 << 20, closefd=False)
    zeros = bytes(1 << 20)
    for _ in range(64):
        writer.write(zeros)
    writer.close()
    data, at = _one_chunk()
    bad, _ = _chunk_with(data, at, 1000, frame.getvalue())
    path = tmp_path / 'bomb.mcap'
    path.write_bytes(bad)
    tracemalloc.start()
    try:
        with pytest.raises(RecordingError, match='decompresses to more than the 1000 bytes'):
            read_recording(str(path))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20            # never the 64 MB the frame would make


def _bytes_read():
    with open('/proc/self/io') as f:
        return int(next(line for line in f if line.startswith('rchar')).split()[1])


@pytest.mark.parametrize('header', [False, True])
def test_magic_and_zeros_is_refused_at_its_first_record(tmp_path, header):
    data, _ = _one_chunk()
    head = data[:data.index(b'\x03')] if header else MAGIC      # magic and header record
    path = tmp_path / 'zeros.mcap'
    with open(path, 'wb') as f:
        f.write(head)
        f.truncate(20 << 20)                 # sparse: 20 MB of zeros after it
    before = _bytes_read()
    with pytest.raises(RecordingError, match='opcode 0' if header else 'no header record'):
        read_recording(str(path))
    assert _bytes_read() - before < 1 << 20


def test_replay_and_analyze_of_magic_and_zeros_are_one_line(tmp_path, capsys):
    path = tmp_path / 'zeros.mcap'
    with open(path, 'wb') as f:
        f.write(MAGIC)
        f.truncate(20 << 20)
    for argv in (['replay', str(path), '-o', str(tmp_path / 'o.mcap')],
                 ['analyze', str(path), '--out', str(tmp_path / 'an')],
                 ['picture', str(path), '-o', str(tmp_path / 'p.png')]):
        err = one_line_error(capsys, argv)
        assert f'{path}: damaged file (no header record after its magic)' in err, err


def test_a_finished_file_with_a_damaged_summary_is_refused_not_cut_short(
        clip, tmp_path, capsys):
    data = clip.read_bytes()
    footer = len(data) - 8 - 29
    summary_start = struct.unpack_from('<Q', data, footer + 9)[0]
    bad = bytearray(data)
    bad[summary_start + 1:summary_start + 9] = struct.pack('<Q', 1 << 31)   # a record's length
    damaged = tmp_path / 'damaged.mcap'
    damaged.write_bytes(bytes(bad))
    err = one_line_error(capsys, ['replay', str(damaged), '-o', str(tmp_path / 'out.mcap')])
    assert f'{damaged}: damaged file' in err, err
    # Without its summary and footer (a kill -9 while recording): still replayed, as a cut.
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:summary_start - 13])       # before its DataEnd record
    assert main(['replay', str(cut), '-o', str(tmp_path / 'out.mcap')]) == 0
    assert 'cut short' in capsys.readouterr().err


def test_replay_reads_the_recording_in_two_passes(clip, tmp_path, monkeypatch):
    # Its topics and set-up, then its inputs: never a third pass to tell a crowd's.
    from jacket_cloth_ros.recording import reader
    files = []
    original = reader._read_file
    monkeypatch.setattr(reader, '_read_file',
                        lambda path, *args: files.append(path) or original(path, *args))
    assert main(['replay', str(clip), '-o', str(tmp_path / 'out.mcap')]) == 0
    assert files == [str(clip)] * 2


def test_a_bag_listing_one_file_twice_is_refused(clip, tmp_path, capsys):
    import shutil
    bag = tmp_path / 'bag'
    bag.mkdir()
    shutil.copy(clip, bag / 'a.mcap')
    (bag / 'b.mcap').symlink_to('a.mcap')
    for listed in (['a.mcap'] * 1000, ['a.mcap', './b.mcap']):
        (bag / 'metadata.yaml').write_text(
            'rosbag2_bagfile_information:\n  storage_identifier: mcap\n'
            f'  relative_file_paths: {listed}\n')
        err = one_line_error(capsys, ['replay', str(bag), '-o', str(tmp_path / 'o.mcap')])
        assert f'{bag / "metadata.yaml"}: lists ' in err and 'twice' in err, err


def test_a_bag_whose_metadata_lists_no_files_says_so(clip, tmp_path, capsys):
    # It said "a directory without .mcap files" of a folder holding one (a hostile probe).
    import shutil
    bag = tmp_path / 'bag'
    bag.mkdir()
    shutil.copy(clip, bag / 'bag_0.mcap')
    (bag / 'metadata.yaml').write_text('rosbag2_bagfile_information:\n  storage_identifier: '
                                       'mcap\n  relative_file_paths: []\n')
    err = one_line_error(capsys, ['replay', str(bag), '-o', str(tmp_path / 'o.mcap')])
    assert err == (f'jacket_cloth replay: {bag / "metadata.yaml"}: lists no files '
                   '(relative_file_paths is empty)')


@pytest.fixture(scope='module')
def replayed(clip, tmp_path_factory):
    """The clip's replay: its inputs and the set-up record the node writes."""
    from jacket_cloth_ros.recording.writer import SESSION_CONFIG
    path = tmp_path_factory.mktemp('replayed') / 'full.mcap'
    assert main(['replay', str(clip), '-o', str(path)]) == 0
    recording = read_recording(str(path))
    inputs = [(m.data, m.log_time) for m in recording.messages if m.topic == '/joint_states']
    return inputs, recording.metadata[SESSION_CONFIG]


def _with_setup(inputs, setup, path):
    """A recording of ``inputs`` whose set-up record is ``setup`` (any texts)."""
    from jacket_cloth_ros.recording.writer import (
        SESSION_CONFIG, SessionRecorder, qos_profile_yaml)
    rec = SessionRecorder(str(path))
    rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    rec.add_metadata(SESSION_CONFIG, setup)
    for data, stamp in inputs:
        rec.write('/joint_states', data, stamp)
    rec.close()


def _parameters(setup, **changes):
    import json
    values = json.loads(setup['parameters_json'])
    values.update(changes)
    return {**setup, 'parameters_json': json.dumps(values)}


@pytest.mark.parametrize('change, expected', [
    (lambda s: _parameters(s, **{'fabric.iterations': 1e9}), 'parameter fabric.iterations'),
    (lambda s: _parameters(s, **{'fabric.iterations': 10 ** 9}), 'outside [1, 100]'),
    (lambda s: _parameters(s, **{'fabric.damping': float('nan')}), 'parameter fabric.damping'),
    (lambda s: _parameters(s, fabric_preset=5), 'parameter fabric_preset'),
    (lambda s: _parameters(s, wind='x'), 'parameter wind'),
    (lambda s: _parameters(s, sim_rate=[1]), 'parameter sim_rate'),
    (lambda s: {**s, 'parameters_json': '[1, 2]'}, 'not a JSON object'),
    (lambda s: {**s, 'parameters_json': '{'}, 'not JSON'),
    (lambda s: {**s, 'parameters_json': '[' * 100000}, 'not JSON'),
    (lambda s: {**s, 'urdf': '<robot'}, 'the recorded URDF'),
    (lambda s: {**s, 'rig_yaml': '[1]'}, 'the recorded rig'),
    (lambda s: {**s, 'fabrics_yaml': 'tweed_jacket: {damping: .nan}'}, 'the recorded fabrics'),
])
def test_a_recorded_set_up_is_validated_as_files_and_parameters_are(
        replayed, tmp_path, capsys, change, expected):
    inputs, setup = replayed
    path = tmp_path / 'setup.mcap'
    _with_setup(inputs, change(setup), path)
    for argv in (['replay', str(path), '-o', str(tmp_path / 'o.mcap')],
                 ['analyze', str(path), '--out', str(tmp_path / 'an')]):
        err = one_line_error(capsys, argv)
        assert str(path) in err and expected in err, err


def test_replay_never_writes_over_a_file_of_its_input_bag(clip, tmp_path, capsys):
    import shutil
    for how in ('metadata', 'link'):
        target = tmp_path / f'{how}.mcap'
        shutil.copy(clip, target)
        kept = target.read_bytes()
        bag = tmp_path / f'bag_{how}'
        bag.mkdir()
        if how == 'metadata':           # listed as ../metadata.mcap
            (bag / 'metadata.yaml').write_text(
                'rosbag2_bagfile_information:\n  storage_identifier: mcap\n'
                f'  relative_file_paths: [../{target.name}]\n')
        else:                           # a link in the bag, no metadata.yaml
            (bag / 'a.mcap').symlink_to(target)
        err = one_line_error(capsys, ['replay', str(bag), '-o', str(target), '--force'])
        assert f'{target} is the input' in err, err
        assert target.read_bytes() == kept


_BVH = ('HIERARCHY\nROOT Hips\n{{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition '
        'Zrotation Xrotation Yrotation\n  JOINT Spine\n  {{\n    OFFSET {offset}\n'
        '    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {{\n'
        '      OFFSET 0 10 0\n    }}\n  }}\n}}\nMOTION\nFrames: 3\nFrame Time: {time}\n'
        + '0 90 0 0 0 0 0 0 0\n' * 3)


@pytest.mark.parametrize('offset, time, expected', [
    ('0 10 0', '0.01', None),
    ('0 10 0', '1e8', 'Frame Time 1e+08 is outside [0.0001, 1] s'),
    ('0 10 0', '1e-12', 'Frame Time 1e-12 is outside [0.0001, 1] s'),
    ('0 nan 0', '0.01', 'the OFFSET of Spine is not three finite numbers'),
])
def test_a_bvh_frame_time_or_offset_out_of_range_is_refused(
        tmp_path, capsys, offset, time, expected):
    src = tmp_path / 'c.bvh'
    src.write_text(_BVH.format(offset=offset, time=time))
    argv = ['import', str(src), '-o', str(tmp_path / 'o.mcap'), '--urdf-out',
            str(tmp_path / 'c.urdf')]
    if expected is None:
        assert main(argv) == 0
    else:
        err = one_line_error(capsys, argv)
        assert f'{src}: {expected}' in err, err


@pytest.mark.parametrize('option, value, expected', [
    ('--start', '1e10', '--start 1e+10 is outside [0, 2e+09] s'),
    ('--start', 'inf', '--start inf is outside'), ('--start', '-5', '--start -5 is outside'),
    ('--start', 'nan', '--start nan is outside'),
    ('--rate', '0', '--rate 0 is outside [0.1, 1000] Hz'), ('--rate', 'inf', '--rate inf'),
    ('--rate', '-5', '--rate -5 is outside'), ('--duration', '1e9', '--duration 1e+09'),
])
def test_a_motion_number_out_of_range_is_refused(tmp_path, capsys, option, value, expected):
    out = tmp_path / 'o.mcap'
    err = one_line_error(capsys, ['motion', '--clip', 'walk', '-o', str(out), option, value])
    assert expected in err, err
    assert not out.exists()


def test_import_start_and_picture_analyze_moments_out_of_range_are_refused(
        clip, tmp_path, capsys):
    src = tmp_path / 'c.bvh'
    src.write_text(_BVH.format(offset='0 10 0', time='0.01'))
    for argv, expected in (
            (['import', str(src), '-o', str(tmp_path / 'o.mcap'), '--start', '-5'], '--start -5'),
            (['picture', str(clip), '-o', str(tmp_path / 'p.png'), '--moments', '1000000000'],
             '--moments 1e+09 is outside [1, 24] frames'),
            (['analyze', str(clip), '--out', str(tmp_path / 'an'), '--moments', '0'],
             '--moments 0 is outside')):
        assert expected in one_line_error(capsys, argv)


def test_a_fifo_or_a_folder_as_an_input_is_refused_unopened(clip, tmp_path, capsys):
    import os
    from jacket_cloth_ros.core.config import ConfigError
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.ros.characters import load_characters
    fifo, folder = tmp_path / 'pipe.mcap', tmp_path / 'folder.yaml'
    os.mkfifo(fifo)
    folder.mkdir()
    out = str(tmp_path / 'o.mcap')
    for path, kind in ((fifo, 'a FIFO'), (folder, 'a folder')):
        for argv in (['replay', str(clip), '-o', out, '--rig', str(path)],
                     ['replay', str(clip), '-o', out, '--urdf', str(path)],
                     ['import', str(path), '-o', out],
                     ['picture', str(clip), '-o', str(tmp_path / 'p.png'), '--rig', str(path)],
                     ['motion', '--urdf', str(path), '-o', out]):
            err = one_line_error(capsys, argv)
            assert f'{path}: {kind}, not a regular file' in err, (argv, err)
    err = one_line_error(capsys, ['replay', str(fifo), '-o', out])
    assert f'{fifo}: a FIFO, not a regular file' in err, err
    # The node's file parameters load through the same readers.
    for load in (lambda: load_characters(str(fifo)), lambda: load_rig(None, str(fifo))):
        with pytest.raises(ConfigError, match='a FIFO, not a regular file'):
            load()


def _chain_urdf(n):
    links = ''.join(f'<link name="l{i}"/>' for i in range(n))
    joints = ''.join(f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/>'
                     f'<child link="l{i}"/><origin xyz="0 0 0.01"/><axis xyz="0 0 1"/>'
                     '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
                     for i in range(1, n))
    return f'<robot name="chain">{links}{joints}</robot>'


def test_urdf_loading_compares_link_names_a_number_of_times_linear_in_links(monkeypatch):
    # A list search per link made 40,000 links 18 s: count the name comparisons instead.
    from urdf_parser_py import urdf
    from jacket_cloth_ros.core import skeleton as module
    compared = [0]

    class Name(str):
        __hash__ = str.__hash__

        def __eq__(self, other):
            compared[0] += 1
            return str.__eq__(self, other)

    parse = urdf.URDF.from_xml_string

    def counted(text):
        robot = parse(text)
        for joint in robot.joints:
            joint.child, joint.parent = Name(joint.child), Name(joint.parent)
        return robot
    monkeypatch.setattr(module.urdf.URDF, 'from_xml_string', counted)
    for n in (500, 2000):
        compared[0] = 0
        assert len(module.Skeleton(_chain_urdf(n)).link_names) == n
        assert compared[0] <= 4 * n, (n, compared[0])


def test_a_urdf_over_the_bounds_is_refused_before_it_is_parsed(monkeypatch):
    # Issue 38 items 5 and 6: 40,000 links stalled every character's /tf for seconds and a
    # 50 MB URDF blocked the node for half an hour; refused before the parser sees them.
    from urdf_parser_py import urdf
    from jacket_cloth_ros.core import skeleton as module
    from jacket_cloth_ros.core.config import ConfigError

    def never(text):
        raise AssertionError('parsed')
    monkeypatch.setattr(module.urdf.URDF, 'from_xml_string', never)
    with pytest.raises(ConfigError, match=f'URDF: 5000 links, over the {module.MAX_LINKS}'):
        module.Skeleton(_chain_urdf(5000))
    big = _chain_urdf(3)[:-len('</robot>')] + ' ' * module.MAX_URDF_CHARS + '</robot>'
    with pytest.raises(ConfigError, match='characters, over the'):
        module.Skeleton(big)
    assert urdf.URDF.from_xml_string is never


def test_a_file_of_unknown_records_is_refused_after_a_bounded_count(tmp_path):
    from jacket_cloth_ros.recording.reader import MAX_UNKNOWN_RECORDS
    data, _ = _one_chunk()
    head = data[:data.index(b'\x03')]                   # magic and header record
    path = tmp_path / 'unknown.mcap'
    path.write_bytes(head + struct.pack('<BQ', 0x80, 0) * (2 * MAX_UNKNOWN_RECORDS))
    before = _bytes_read()
    with pytest.raises(RecordingError, match=f'over {MAX_UNKNOWN_RECORDS} records of unknown'):
        read_recording(str(path))
    assert _bytes_read() - before < 2 * 9 * MAX_UNKNOWN_RECORDS


def test_a_crowd_recordings_set_ups_are_validated_too(replayed, tmp_path, capsys):
    from jacket_cloth_ros.recording.writer import (
        SESSION_CONFIG, SessionRecorder, qos_profile_yaml)
    inputs, setup = replayed
    for change, expected in (({'urdf': ''}, 'has no urdf'),
                             (_parameters(setup, **{'fabric.damping': float('nan')}),
                              'a parameter fabric.damping')):
        path = tmp_path / 'crowd.mcap'
        if path.exists():
            path.unlink()
        rec = SessionRecorder(str(path))
        rec.add_topic('/a/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
        rec.add_metadata(f'{SESSION_CONFIG}/a', {**setup, **change})
        for data, stamp in inputs:
            rec.write('/a/joint_states', data, stamp)
        rec.close()
        err = one_line_error(capsys, ['replay', str(path), '-o', str(tmp_path / 'o.mcap')])
        assert f'{path}: a' in err and expected in err, err


def test_a_file_begun_mid_session_is_said_by_its_replay_and_not_by_the_replays(
        replayed, tmp_path, capsys):
    # A file a live record change opened counts the inputs before it; its replay says so, and
    # the replay's own file, which starts from its first input, no more (a review: the crowd's
    # replay copied the count on).
    from jacket_cloth_ros.recording.writer import (
        SESSION_CONFIG, SessionRecorder, qos_profile_yaml)
    inputs, setup = replayed
    said = 'it began 42 inputs into the live session'
    for crowd in (False, True):
        path, out = tmp_path / f'late_{crowd}.mcap', tmp_path / f'o_{crowd}.mcap'
        topic, name = ('/a/joint_states', f'{SESSION_CONFIG}/a') if crowd else \
            ('/joint_states', SESSION_CONFIG)
        rec = SessionRecorder(str(path))
        rec.add_topic(topic, 'sensor_msgs/msg/JointState', qos_profile_yaml())
        rec.add_metadata(name, {**setup, 'inputs_before': '42'})
        for data, stamp in inputs:
            rec.write(topic, data, stamp)
        rec.close()
        assert main(['replay', str(path), '-o', str(out)]) == 0
        assert said in capsys.readouterr().err, crowd
        assert 'inputs_before' not in read_recording(str(out)).metadata[name], crowd
        assert main(['replay', str(out), '-o', str(tmp_path / f'again_{crowd}.mcap')]) == 0
        assert said not in capsys.readouterr().err, crowd


@pytest.mark.parametrize('durations, words', [
    ([1e8, 1e8], 'its frames last 1e+08 s, outside [0.0001, 1] s'),
    ([1e-4, 1e-4, 1e8, 0], 'resampled every 0.0001 s, would be 1000000000002, over 100000'),
])
def test_a_deepmimic_clip_of_absurd_frame_times_is_refused(tmp_path, capsys, durations,
                                                           words):
    import json
    from fetched import fetched
    from jacket_cloth_ros.motion.deepmimic import read_frames
    frames = read_frames(fetched('humanoid3d_walk.txt'))[:len(durations)].tolist()
    for frame, duration in zip(frames, durations):
        frame[0] = duration
    clip = tmp_path / 'clip.txt'
    clip.write_text(json.dumps({'Frames': frames}))
    err = one_line_error(capsys, ['import', str(clip), '--urdf', fetched('humanoid.urdf'),
                                  '-o', str(tmp_path / 'o.mcap')])
    assert words in err, err


def test_a_file_cut_inside_its_closing_magic_is_cut_short_not_damaged(tmp_path):
    # A writer killed after its footer, before the last magic bytes, wrote every message.
    from jacket_cloth_ros.recording.reader import read_messages
    full = tmp_path / 'walk.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '0.5', '-o', str(full)]) == 0
    data = full.read_bytes()
    messages, complete = read_messages(str(full))
    assert complete and messages
    for cut in range(1, 8):
        path = tmp_path / f'cut{cut}.mcap'
        path.write_bytes(data[:-cut])
        got, complete = read_messages(str(path))
        assert not complete and [m.data for m in got] == [m.data for m in messages], cut


def test_a_bag_folder_without_metadata_holding_a_file_twice_names_the_folder(
        clip, tmp_path, capsys):
    # The line named <bag>/metadata.yaml, a file that is not there.
    import shutil
    bag = tmp_path / 'bag'
    bag.mkdir()
    shutil.copy(clip, bag / 'a.mcap')
    (bag / 'b.mcap').symlink_to('a.mcap')
    err = one_line_error(capsys, ['replay', str(bag), '-o', str(tmp_path / 'o.mcap')])
    assert 'metadata.yaml' not in err, err
    assert f'{bag}: holds {bag / "a.mcap"} twice ({bag / "b.mcap"} is a link to it)' in err, err


@pytest.mark.parametrize('name, recording', [('out.png', False), ('out.mcap', True),
                                             ('bag', True)])
def test_an_output_made_while_a_tool_runs_is_refused_not_overwritten(tmp_path, name,
                                                                     recording):
    # The tools checked that the output was free, ran, then renamed over whatever was there.
    from jacket_cloth_ros.tools.outputs import OutputError, replacing
    path = tmp_path / name
    with pytest.raises(OutputError, match=f'^{path} exists \\(use --force to overwrite\\)$'):
        with replacing(path, recording=recording) as tmp:
            if name == 'bag':
                os.mkdir(tmp)
                path.mkdir()
                (path / 'theirs').write_text('made while the tool ran')
            else:
                with open(tmp, 'w') as f:
                    f.write('ours')
                path.write_text('made while the tool ran')
    kept = path / 'theirs' if name == 'bag' else path
    assert kept.read_text() == 'made while the tool ran'
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]       # no scratch left
    with replacing(path, recording=recording, force=True) as tmp:     # --force: replaced
        if name == 'bag':
            os.mkdir(tmp)
        with open(os.path.join(tmp, 'ours') if name == 'bag' else tmp, 'w') as f:
            f.write('ours')
    assert (path / 'ours' if name == 'bag' else path).read_text() == 'ours'


def test_an_analyze_output_made_while_it_runs_is_refused_not_overwritten(
        clip, tmp_path, capsys, monkeypatch):
    from jacket_cloth_ros.tools import analyze
    out = tmp_path / 'an'
    original = analyze.analyze

    def and_meanwhile(sessions, out_dir, **kwargs):
        (out / 'report.json').write_text('made while analyze ran')
        return original(sessions, out_dir, **kwargs)
    monkeypatch.setattr(analyze, 'analyze', and_meanwhile)
    err = one_line_error(capsys, ['analyze', str(clip), '--out', str(out), '--moments', '2'])
    assert err.endswith(f'{out / "report.json"} exists (use --force to overwrite)'), err
    assert (out / 'report.json').read_text() == 'made while analyze ran'
    # All or nothing: no new chart beside someone else's report, and no scratch left.
    assert [p.name for p in out.iterdir()] == ['report.json']


def test_a_picture_holds_the_markers_it_draws_not_the_sessions(tmp_path):
    # Every MarkerArray's bytes were held to draw six: a long session's picture took as much
    # memory as its markers. Now the peak is about a chunk and the frames drawn.
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.skeleton import load_skeleton
    from jacket_cloth_ros.recording.reader import count_messages
    from jacket_cloth_ros.tools.picture import MARKER_ARRAY, moments_at, recorded_frames
    clip = tmp_path / 'clip.mcap'
    session = tmp_path / 'session.mcap'
    assert main(['motion', '--clip', 'showcase', '--duration', '40', '-o', str(clip)]) == 0
    assert main(['replay', str(clip), '-o', str(session), '-p',
                 'record_compression:=none']) == 0
    sizes = [len(m.data) for m in read_recording(str(session), kinds=(MARKER_ARRAY,)).messages]
    skeleton = load_skeleton(shipped('character.urdf'))
    tracemalloc.start()
    try:
        frames, _ = recorded_frames(str(session), skeleton, load_rig(skeleton),
                                    moments_at(None, 3))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(frames) == 3 and len(sizes) > 50
    assert peak < sum(sizes) / 4, (peak, sum(sizes), count_messages(str(session)))


# Issue 48: hostile input, round four (files and tools).

def _twice(text, key, value):
    """``text`` (a YAML file) with ``key: value`` given again at its end, at the top level."""
    return text.rstrip('\n') + f'\n{key}: {value}\n'


@pytest.mark.parametrize('name, key, value', [
    ('jacket_rig.yaml', 'colliders', '[]'), ('fabrics.yaml', 'tweed_jacket', '{}'),
    ('crowd.yaml', 'characters', '[]')])
def test_a_key_given_twice_in_a_config_file_is_refused_with_both_lines(
        tmp_path, name, key, value):
    # A rig ending in a second ``colliders: []`` ran with no colliders: the last one won.
    from jacket_cloth_ros.core.config import ConfigError, shipped
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.skeleton import load_skeleton
    from jacket_cloth_ros.ros.characters import load_characters
    text = open(shipped(name), encoding='utf-8').read()
    first = 1 + next(k for k, line in enumerate(text.splitlines()) if line.startswith(key + ':'))
    path = tmp_path / name
    path.write_text(_twice(text, key, value))
    load = {'jacket_rig.yaml': lambda: load_rig(load_skeleton(shipped('character.urdf')),
                                                str(path)),
            'fabrics.yaml': lambda: load_fabrics(str(path)),
            'crowd.yaml': lambda: load_characters(str(path))}[name]
    with pytest.raises(ConfigError) as raised:
        load()
    message = str(raised.value)
    assert message == (f'{path}: line {len(text.splitlines()) + 1}: {key!r} is given twice '
                       f'(first at line {first}), and a YAML reader keeps only the last'), message


def test_a_key_given_twice_in_a_recorded_set_up_or_a_bag_is_refused(
        replayed, clip, tmp_path, capsys):
    import json
    inputs, setup = replayed
    cases = [({**setup, 'rig_yaml': _twice(setup['rig_yaml'], 'colliders', '[]')},
              "the recorded rig: line"),
             ({**setup, 'fabrics_yaml': _twice(setup['fabrics_yaml'], 'tweed_jacket', '{}')},
              'the recorded fabrics: line'),
             ({**setup, 'parameters_json': json.dumps(json.loads(setup['parameters_json']))[:-1]
               + ', "sim_rate": 130}'}, "the recorded parameters: 'sim_rate' is")]
    for k, (changed, expected) in enumerate(cases):
        path = tmp_path / f'setup{k}.mcap'
        _with_setup(inputs, changed, path)
        err = one_line_error(capsys, ['replay', str(path), '-o', str(tmp_path / 'o.mcap')])
        assert f'{path}: {expected}' in err and 'given twice' in err, err
    bag = tmp_path / 'bag'
    bag.mkdir()
    (bag / 'a.mcap').write_bytes(clip.read_bytes())
    (bag / 'metadata.yaml').write_text(
        'rosbag2_bagfile_information:\n  storage_identifier: mcap\n'
        '  relative_file_paths: [a.mcap]\n  relative_file_paths: []\n')
    err = one_line_error(capsys, ['replay', str(bag), '-o', str(tmp_path / 'o.mcap')])
    assert "'relative_file_paths' is given twice (first at line 3)" in err, err


def _flipped(path, at, bit=0):
    data = bytearray(path.read_bytes())
    data[at] ^= 1 << bit
    return bytes(data)


def test_a_bit_flipped_in_the_recorded_set_up_fails_the_files_crc(replayed, clip, tmp_path,
                                                                  capsys):
    # DataEnd's CRC was 0: sim_rate 120 -> 130 (one bit) replayed at 130 Hz with exit 0.
    full = tmp_path / 'full.mcap'
    assert main(['replay', str(clip), '-o', str(full)]) == 0
    data = full.read_bytes()
    at = data.index(b'"sim_rate": 120') + len('"sim_rate": 1')
    path = tmp_path / 'flipped.mcap'
    path.write_bytes(_flipped(full, at))
    assert b'"sim_rate": 130' in path.read_bytes()
    err = one_line_error(capsys, ['replay', str(path), '-o', str(tmp_path / 'o.mcap')])
    assert err.endswith(f'{path}: damaged file (its data section fails its CRC check: a byte '
                        'of its set-up, channels or messages changed after it was written); '
                        'nothing read'), err


def _tailed_character(n):
    """The shipped character with a chain of ``n`` links hanging from its pelvis (a tail)."""
    from jacket_cloth_ros.core.config import shipped
    text = open(shipped('character.urdf'), encoding='utf-8').read()
    links = ''.join(f'<link name="tail{i}"/>' for i in range(n))
    parents = ['base_link'] + [f'tail{i}' for i in range(n - 1)]
    joints = ''.join(
        f'<joint name="tail_j{i}" type="revolute"><parent link="{parent}"/><child '
        f'link="tail{i}"/><origin xyz="{-0.1 if i == 0 else 0} 0 {0 if i == 0 else -0.0005}"/>'
        '<axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i, parent in enumerate(parents))
    return text.replace('</robot>', links + joints + '</robot>')


def test_a_rig_is_proposed_for_a_character_with_a_tail_of_a_thousand_links(tmp_path, capsys):
    # The proposal counted leaves by a recursion per link: a RecursionError traceback.
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.skeleton import MAX_LINKS, load_skeleton
    urdf = tmp_path / 'tailed.urdf'
    urdf.write_text(_tailed_character(MAX_LINKS - 40))
    out = tmp_path / 'rig.yaml'
    assert main(['rig', '--urdf', str(urdf), '-o', str(out)]) == 0, capsys.readouterr().err
    skeleton = load_skeleton(str(urdf))
    assert len(skeleton.link_names) > 2000
    assert load_rig(skeleton, str(out)).rows > 0


def _fan_bvh(joints):
    """A BVH whose root carries ``joints`` joints of three rotation channels and an end each."""
    parts = ['HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition '
             'Zposition Zrotation Xrotation Yrotation\n']
    parts += [f'  JOINT J{i}\n  {{\n    OFFSET 0 10 0\n    CHANNELS 3 Zrotation Xrotation '
              'Yrotation\n    End Site\n    {\n      OFFSET 0 10 0\n    }\n  }\n'
              for i in range(joints)]
    row = ' '.join(['0'] * (6 + 3 * joints)) + '\n'
    return ''.join(parts) + '}\nMOTION\nFrames: 2\nFrame Time: 0.01\n' + row * 2


@pytest.mark.parametrize('text, expected', [
    (_BVH.format(offset='0 1e305 0', time='0.01'), 'the OFFSET of Spine reaches 1e+302 m at '
     '0.001 m per unit, beyond the 1000 m a skeleton may'),
    (_fan_bvh(600), 'its skeleton would be 2401 links as a URDF, over the 2048 a character '
     'may have'),
])
def test_import_refuses_a_skeleton_no_tool_takes_before_writing(
        tmp_path, capsys, text, expected):
    # It wrote a URDF of 1e302 m bones, or of 30,002 links, that every other tool refused.
    src = tmp_path / 'c.bvh'
    src.write_text(text)
    out, urdf = tmp_path / 'o.mcap', tmp_path / 'c.urdf'
    err = one_line_error(capsys, ['import', str(src), '-o', str(out), '--urdf-out', str(urdf)])
    assert err == f'jacket_cloth import: {src}: {expected}', err
    assert not out.exists() and not urdf.exists()
    # Within the limits, what it writes loads.
    src.write_text(_fan_bvh(500))
    assert main(['import', str(src), '-o', str(out), '--urdf-out', str(urdf)]) == 0
    from jacket_cloth_ros.core.skeleton import load_skeleton
    assert len(load_skeleton(str(urdf)).link_names) == 2001


@pytest.mark.parametrize('encoding', ['json', 'protobuf', 'ros1'])
def test_a_channel_declared_in_another_encoding_is_refused_not_decoded_as_cdr(
        replayed, tmp_path, capsys, encoding):
    inputs, _ = replayed
    out = io.BytesIO()
    w = McapWriter(out, compression='zstd')
    w.start(profile='ros2', library='test')
    from jacket_cloth_ros.recording.definitions import ros2msg_schema
    schema = w.register_schema('sensor_msgs/msg/JointState', 'ros2msg',
                               ros2msg_schema('sensor_msgs/msg/JointState').encode())
    channel = w.register_channel('/joint_states', encoding, schema)
    for data, stamp in inputs:          # CDR bytes: today's reader replayed them as such
        w.add_message(channel, stamp, data, stamp)
    w.finish()
    path = tmp_path / f'{encoding}.mcap'
    path.write_bytes(out.getvalue())
    for argv in (['replay', str(path), '-o', str(tmp_path / 'o.mcap')],
                 ['picture', str(path), '-o', str(tmp_path / 'p.png'), '--urdf',
                  _shipped('character.urdf')]):
        err = one_line_error(capsys, argv)
        assert err.endswith(f"{path}: /joint_states (sensor_msgs/msg/JointState) is declared "
                            f"'{encoding}'-encoded; only cdr (ROS 2) messages are read"), err


def _shipped(name):
    from jacket_cloth_ros.core.config import shipped
    return shipped(name)


def test_unknown_keys_of_a_recorded_set_up_are_named_in_one_warning(replayed, tmp_path, capsys):
    # The node refuses a parameter it does not have; a replay dropped them without a word.
    inputs, setup = replayed
    path = tmp_path / 'newer.mcap'
    _with_setup(inputs, {**_parameters(setup, sim_rte=90.0), 'urdf_v2': '<robot/>'}, path)
    capsys.readouterr()
    assert main(['replay', str(path), '-o', str(tmp_path / 'o.mcap')]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if 'warning' in line]
    assert warnings == [f'jacket_cloth replay: warning: {path}: its recorded set-up holds what '
                        "this version does not know (ignored): key(s) 'urdf_v2'; parameter(s) "
                        "'sim_rte'"], warnings


def test_a_picture_of_inputs_only_says_what_it_found_and_what_it_needs(clip, tmp_path, capsys):
    err = one_line_error(capsys, ['picture', str(clip), '-o', str(tmp_path / 'p.png'),
                                  '--urdf', _shipped('character.urdf')])
    assert err.endswith(f"{clip}: nothing to draw: it holds 61 JointState and 0 MarkerArray "
                        "messages; a picture needs the simulation's markers: replay it with "
                        'them first (jacket_cloth replay IN -o OUT -p markers_rate:=30.0), then '
                        'draw OUT'), err
    # The advice taken on a session recorded without markers gives a file to draw (it gave
    # another without them: the replay keeps the recorded markers_rate; a probe).
    bare, out = tmp_path / 'bare.mcap', tmp_path / 'out.mcap'
    assert main(['replay', str(clip), '-o', str(bare), '-p', 'markers_rate:=0.0']) == 0
    one_line_error(capsys, ['picture', str(bare), '-o', str(tmp_path / 'b.png')])
    assert main(['replay', str(bare), '-o', str(out), '-p', 'markers_rate:=30.0']) == 0
    assert main(['picture', str(out), '-o', str(tmp_path / 'o.png')]) == 0


def test_a_mimic_cycle_is_named_as_one_and_a_mimic_of_a_mimic_follows_its_source():
    from jacket_cloth_ros.core.config import ConfigError
    from jacket_cloth_ros.core.skeleton import Skeleton

    def joint(name, child, mimic=None, factor=1.0, offset=0.0):
        follows = '' if mimic is None else \
            f'<mimic joint="{mimic}" multiplier="{factor}" offset="{offset}"/>'
        return (f'<joint name="{name}" type="revolute"><parent link="l{child - 1}"/><child '
                f'link="l{child}"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" '
                f'velocity="1"/>{follows}</joint>')
    links = ''.join(f'<link name="l{i}"/>' for i in range(4))
    robot = '<robot name="r">' + links + '{}</robot>'
    with pytest.raises(ConfigError, match=r"^URDF: 2 joints mimic each other in a cycle "
                       r"\(a -> b -> a\): none follows a joint that moves$"):
        Skeleton(robot.format(joint('a', 1, 'b') + joint('b', 2, 'a') + joint('c', 3)))
    with pytest.raises(ConfigError, match="^URDF: joint 'a' mimics itself"):
        Skeleton(robot.format(joint('a', 1, 'a') + joint('b', 2) + joint('c', 3)))
    # a = 2 b + 0.1, b = 3 c + 0.2: a = 6 c + 0.5, as joint_state_publisher computes it.
    sk = Skeleton(robot.format(joint('a', 1, 'b', 2.0, 0.1) + joint('b', 2, 'c', 3.0, 0.2)
                               + joint('c', 3)))
    assert sk.joint_names == ['c']
    assert sk.mult[1:].tolist() == [6.0, 3.0, 1.0]
    assert sk.offset[1:].tolist() == pytest.approx([0.5, 0.2, 0.0])


def test_an_animation_named_as_its_filmstrip_is_refused_before_either_is_written(
        clip, tmp_path, capsys):
    # --animate writes <name>.gif beside the filmstrip: with -o x.gif the animation replaced
    # the filmstrip just written, and both were reported written (a hostile probe).
    for name in ('strip.gif', 'strip.GIF'):          # one file where case is not told apart
        out = tmp_path / name
        err = one_line_error(capsys, ['picture', str(clip), '-o', str(out), '--animate'])
        assert err == (f'jacket_cloth picture: --animate writes the animation to '
                       f'{tmp_path / "strip.gif"}, the filmstrip\'s own name: give the '
                       'filmstrip another extension (.png)')
        assert os.listdir(tmp_path) == []


@pytest.mark.parametrize('name', ['strip', 'strip.txt'])
def test_a_picture_whose_name_names_no_format_is_refused_up_front(
        clip, tmp_path, capsys, name):
    # An extension-less name failed at the save with matplotlib's "Format 'partial' is not
    # supported", the suffix of the tool's own temporary file.
    err = one_line_error(capsys, ['picture', str(clip), '-o', str(tmp_path / name)])
    assert 'partial' not in err and 'end the name in .png' in err, err
    assert os.listdir(tmp_path) == []


def test_a_rig_whose_picture_cannot_be_made_is_not_written_either(tmp_path, capsys,
                                                                  monkeypatch):
    # The rig's YAML was put in place before its picture was drawn: a picture that failed (a
    # bad extension, a full disk) left a rig that the run again then refused to overwrite.
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.rigging import picture
    urdf = shipped('character.urdf')
    argv = ['rig', '--urdf', urdf, '-o', str(tmp_path / 'rig.yaml')]
    err = one_line_error(capsys, argv + ['--picture', str(tmp_path / 'rig.txt')])
    assert 'rig.txt: .txt is not a picture format' in err, err

    def full_disk(*args, **kwargs):
        raise OSError(28, 'No space left on device')
    monkeypatch.setattr(picture, 'draw_rig', full_disk)
    err = one_line_error(capsys, argv + ['--picture', str(tmp_path / 'rig.png')])
    assert 'No space left on device' in err, err
    assert os.listdir(tmp_path) == []


def test_a_replay_the_simulation_took_nothing_of_is_a_failure_and_no_file(tmp_path, capsys):
    # Every input refused (non-finite positions): the replay wrote a file of the inputs alone,
    # no /tf, markers or diagnostics, and exited 0 (a hostile probe).
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
    from jacket_cloth_ros.ros.cdr import joint_state
    names = list(load_shipped_character().joint_names)
    session, out = tmp_path / 'nan.mcap', tmp_path / 'out.mcap'
    recorder = SessionRecorder(str(session))
    recorder.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    for k in range(30):
        stamp = 10 ** 10 + k * 10 ** 9 // 60
        recorder.write('/joint_states', joint_state(stamp, names, [float('nan')] * len(names)),
                       stamp)
    recorder.close()
    err = one_line_error(capsys, ['replay', str(session), '-o', str(out)])
    assert err.startswith(f'jacket_cloth replay: {session}: the simulation took none of its 30 '
                          'JointState messages (the first: non-finite position for '), err
    assert err.endswith('message dropped); nothing written'), err
    assert sorted(os.listdir(tmp_path)) == ['nan.mcap']


def test_a_replay_whose_inputs_never_gave_finite_bones_is_a_failure_and_no_file(
        clip, tmp_path, capsys, monkeypatch):
    # Inputs taken but never a finite pose: the replay wrote the inputs alone, no /tf, and
    # exited 0 (a review); export refused such a session, replay did not.
    from jacket_cloth_ros.core.simulation import JacketSimulation
    real = JacketSimulation.bones

    def never_finite(sim):
        bones = real(sim)
        bones.finite = False
        return bones
    monkeypatch.setattr(JacketSimulation, 'bones', never_finite)
    out = tmp_path / 'out.mcap'
    for argv in (['replay', str(clip), '-o', str(out)], ['export', str(clip), '-o',
                                                         str(tmp_path / 'out.glb')]):
        err = one_line_error(capsys, argv)
        assert f'{clip}: none of the 61 JointState messages the simulation took gave the ' \
            'jacket finite bones; ' in err, err
    assert os.listdir(tmp_path) == []


# The replay a SIGTERM must stop, held at its 100th input until the signal comes: the signal
# then lands inside the replay's loop, with its output open, however loaded the machine.
_HELD_REPLAY = """
import sys, time
from jacket_cloth_ros.ros.pipeline import SessionPipeline
from jacket_cloth_ros.signals import tools
real, taken, here = SessionPipeline.on_raw, [], sys.argv[1]

def held(pipeline, raw):
    taken.append(raw)
    if len(taken) == 100:
        open(here, 'w').close()
        while True:
            time.sleep(0.01)
    return real(pipeline, raw)
SessionPipeline.on_raw = held
sys.argv = ['jacket_cloth'] + sys.argv[2:]
sys.exit(tools())
"""


def test_sigterm_stops_a_replay_as_ctrl_c_does_leaving_no_temporary_file(tmp_path):
    # SIGTERM ended the process where it stood: the output's hidden temporary file stayed.
    import signal
    import subprocess
    import sys
    import time
    work, side = tmp_path / 'work', tmp_path / 'side'
    work.mkdir()
    side.mkdir()
    clip, out, held = work / 'walk.mcap', work / 'out.mcap', side / 'held'
    assert main(['motion', '--clip', 'walk', '--duration', '5', '-o', str(clip)]) == 0
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    tool = subprocess.Popen([sys.executable, '-c', _HELD_REPLAY, str(held), 'replay',
                             str(clip), '-o', str(out)], cwd=root, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True)

    def replaying():
        deadline = time.monotonic() + 120
        while not held.exists():
            assert tool.poll() is None and time.monotonic() < deadline, 'no replay started'
            time.sleep(0.01)
        assert any('.partial' in name for name in os.listdir(work)), os.listdir(work)
    err = signalled(tool, replaying, signal.SIGTERM)
    assert tool.returncode == 143, err
    assert err.strip().splitlines() == ['jacket_cloth replay: stopped by SIGTERM'], err
    assert os.listdir(work) == ['walk.mcap']


def test_sigterm_while_a_file_is_read_is_a_stop_not_a_bad_file(clip, tmp_path, capsys,
                                                               monkeypatch):
    # Stopped was an Exception: the reader's and the URDF parser's `except Exception` took a
    # SIGTERM for a damaged file or a malformed URDF, and exited 1 saying so (a review).
    import signal
    from urdf_parser_py import urdf
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.recording import reader

    def terminated(*args, **kwargs):
        signal.raise_signal(signal.SIGTERM)
    for module, name, argv in (
            (reader._Scan, '_take', ['replay', str(clip), '-o', str(tmp_path / 'o.mcap')]),
            (urdf.URDF, 'from_xml_string', ['rig', '--urdf', shipped('character.urdf'), '-o',
                                            str(tmp_path / 'rig.yaml')])):
        with monkeypatch.context() as patched:
            patched.setattr(module, name, terminated)
            capsys.readouterr()
            assert main(argv) == 128 + signal.SIGTERM
        err = capsys.readouterr().err
        assert err == f'jacket_cloth {argv[0]}: stopped by SIGTERM\n', err
    assert os.listdir(tmp_path) == []
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL      # put back as it was


def test_a_crowd_replay_the_simulation_took_nothing_of_is_a_failure_and_no_file(
        replayed, tmp_path, capsys):
    # The one-character replay refused such a session; a crowd's still wrote its inputs alone
    # and exited 0, and with another character replayed, said nothing of the one without cloth
    # (two reviews).
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.recording.writer import (
        SESSION_CONFIG, SessionRecorder, qos_profile_yaml)
    from jacket_cloth_ros.ros.cdr import joint_state
    inputs, setup = replayed
    names = list(load_shipped_character().joint_names)
    nan = [(joint_state(stamp, names, [float('nan')] * len(names)), stamp)
           for stamp in (10 ** 10 + k * 10 ** 9 // 60 for k in range(20))]

    def crowd(path, b_inputs):
        rec = SessionRecorder(str(path))
        for who in ('a', 'b'):
            rec.add_topic(f'/{who}/joint_states', 'sensor_msgs/msg/JointState',
                          qos_profile_yaml())
            rec.add_metadata(f'{SESSION_CONFIG}/{who}', setup)
        for who, given in (('a', nan), ('b', b_inputs)):
            for data, stamp in given:
                rec.write(f'/{who}/joint_states', data, stamp)
        rec.close()
    out = tmp_path / 'o.mcap'
    for b_inputs in (nan, []):              # b refused too, or never sent a thing
        path = tmp_path / f'crowd{len(b_inputs)}.mcap'
        crowd(path, b_inputs)
        err = one_line_error(capsys, ['replay', str(path), '-o', str(out)])
        assert err.startswith(f'jacket_cloth replay: {path}: a: the simulation took none of its '
                              '20 JointState messages (the first: non-finite position for '), err
        assert err.endswith(", nor of any other character's; nothing written"), err
        assert not out.exists()
    path = tmp_path / 'crowd_b.mcap'
    crowd(path, inputs)
    assert main(['replay', str(path), '-o', str(out)]) == 0
    warned = capsys.readouterr().err.strip().splitlines()
    assert len(warned) == 1 and warned[0].startswith(
        f'jacket_cloth replay: warning: {path}: a: the simulation took none of its 20 '), warned
    # b's inputs taken but no finite bones ever: no character gave cloth, so nothing written.
    from jacket_cloth_ros.core.simulation import JacketSimulation
    real = JacketSimulation.bones

    def never_finite(sim):
        bones = real(sim)
        bones.finite = False
        return bones
    with pytest.MonkeyPatch.context() as patched:
        patched.setattr(JacketSimulation, 'bones', never_finite)
        err = one_line_error(capsys, ['replay', str(path), '-o', str(tmp_path / 'o2.mcap')])
    assert 'the simulation took none of its 20 JointState messages' in err, err
    assert err.endswith(", nor of any other character's; nothing written"), err
    assert not (tmp_path / 'o2.mcap').exists()


def test_a_rig_and_its_picture_of_one_name_and_a_failed_animation_leave_nothing(
        clip, tmp_path, capsys, monkeypatch):
    # rig -o x.png --picture x.png put the YAML in place, then the picture over it (a review);
    # a filmstrip was put in place before its animation, which could then fail.
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.tools import animation
    same = str(tmp_path / 'x.png')
    err = one_line_error(capsys, ['rig', '--urdf', shipped('character.urdf'), '-o', same,
                                  '--picture', same])
    assert err == f"jacket_cloth rig: --picture {same} is the rig's own name: give the " \
        'picture another'

    def full_disk(*args, **kwargs):
        raise OSError(28, 'No space left on device')
    monkeypatch.setattr(animation, 'render_animation', full_disk)
    replay = tmp_path / 'session.mcap'
    assert main(['replay', str(clip), '-o', str(replay)]) == 0
    err = one_line_error(capsys, ['picture', str(replay), '-o', str(tmp_path / 's.png'),
                                  '--animate'])
    assert 'No space left on device' in err, err
    assert sorted(os.listdir(tmp_path)) == ['session.mcap']


@pytest.mark.parametrize('force, renamed', [(True, True), (False, False), (False, True)])
def test_a_signal_at_a_bags_rename_keeps_the_old_bag_and_leaves_no_empty_folder(
        tmp_path, monkeypatch, force, renamed):
    # With --force, a signal as the old bag moved aside let the scratch folder's removal take
    # it; without, one between the placeholder folder and the rename left that empty folder,
    # which every later run refused (a review).
    import signal
    from jacket_cloth_ros.tools import outputs
    from jacket_cloth_ros.tools.live import Stopped
    bag = tmp_path / 'bag'
    if force:
        bag.mkdir()
        (bag / 'metadata.yaml').write_text('the old bag')
    rename = os.rename

    def stopped(src, dst):          # as a signal comes: before the call or as it returns
        monkeypatch.setattr(outputs.os, 'rename', rename)
        if renamed:
            rename(src, dst)
        raise Stopped(signal.SIGTERM)
    with pytest.raises(Stopped):
        with outputs.replacing(str(bag), recording=True, force=force) as tmp:
            os.mkdir(tmp)
            with open(os.path.join(tmp, 'metadata.yaml'), 'w') as f:
                f.write('new')
            monkeypatch.setattr(outputs.os, 'rename', stopped)
    if force:
        assert (bag / 'metadata.yaml').read_text() == 'the old bag'
        assert sorted(os.listdir(tmp_path)) == ['bag']
    elif renamed:
        assert (bag / 'metadata.yaml').read_text() == 'new'      # in place before the signal
    else:
        assert os.listdir(tmp_path) == []
