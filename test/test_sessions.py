# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Replay and analysis of recorded sessions: determinism, reports, foreign and broken files.

Live-versus-replay equality needs the node over DDS: it is in test_node.py.
"""

import io
import json
import os
import shutil

import numpy as np
import pytest
import yaml
from mcap.data_stream import ReadDataStream
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from mcap_ros2.writer import Writer as Ros2Writer

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.recording.definitions import ros2msg_schema
from jacket_cloth_ros.recording.reader import read_messages
from jacket_cloth_ros.tools.cli import main
from jacket_cloth_ros.tools.session import load_session, run_session


@pytest.fixture(scope='module')
def clip(tmp_path_factory):
    """An input-only session: 3 s of the run clip at 60 Hz, as the motion tool writes it."""
    path = tmp_path_factory.mktemp('clip') / 'clip.mcap'
    assert main(['motion', '--clip', 'run', '--duration', '3.0', '-o', str(path)]) == 0
    return path


def _replay(src, dst, *extra):
    return main(['replay', str(src), '-o', str(dst), *extra])


def test_replay_is_byte_identical_run_after_run(clip, tmp_path):
    for folder in ('a', 'b'):
        (tmp_path / folder).mkdir()
        assert _replay(clip, tmp_path / folder / 'out.mcap') == 0
    a = (tmp_path / 'a' / 'out.mcap').read_bytes()
    assert a == (tmp_path / 'b' / 'out.mcap').read_bytes() and len(a) > 50_000
    # Other parameters give another file; a replay of a replay gives the same bones again.
    assert _replay(clip, tmp_path / 'iter3.mcap', '-p', 'fabric.iterations:=3') == 0
    assert (tmp_path / 'iter3.mcap').read_bytes() != a
    assert _replay(clip, tmp_path / 'zstd.mcap', '-p', 'record_compression:=zstd') == 0
    with open(tmp_path / 'zstd.mcap', 'rb') as f:
        assert {c.compression for c in make_reader(f).get_summary().chunk_indexes} == {'zstd'}
    again = load_session(str(tmp_path / 'a' / 'out.mcap'))
    recorded = {m.log_time: m.data for m in read_messages(str(tmp_path / 'a' / 'out.mcap'))[0]
                if m.topic == '/tf'}
    same = []
    run_session(again, probe=lambda p, r, stamp, outs: same.extend(
        recorded[stamp] == data for key, data in outs if key == 'tf'))
    assert len(same) == 181 and all(same)


def test_replay_writes_what_the_node_records_and_an_independent_reader_decodes_it(clip,
                                                                                  tmp_path):
    out = tmp_path / 'out.mcap'
    assert _replay(clip, out) == 0
    with open(out, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = reader.get_summary()
        topics = {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}
        assert topics == {
            '/joint_states': 'sensor_msgs/msg/JointState', '/tf': 'tf2_msgs/msg/TFMessage',
            '/jacket_cloth_node/markers': 'visualization_msgs/msg/MarkerArray',
            '/diagnostics': 'diagnostic_msgs/msg/DiagnosticArray',
            '/jacket_cloth_node/wind': 'geometry_msgs/msg/Vector3Stamped',
            '/jacket_cloth_node/viewer': 'geometry_msgs/msg/PointStamped',
            '/parameter_events': 'rcl_interfaces/msg/ParameterEvent'}
        assert all('offered_qos_profiles' in c.metadata for c in summary.channels.values())
        # Compressed as the node would have (record_compression, lz4 by default).
        assert {c.compression for c in summary.chunk_indexes} == {'lz4'}
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        bag = yaml.safe_load(meta['rosbag2']['serialized_metadata'])
        assert bag['rosbag2_bagfile_information']['relative_file_paths'] == ['out.mcap']
        assert summary.statistics.message_count == bag['rosbag2_bagfile_information'][
            'message_count']
        decoded = {}
        for _, channel, _, msg in reader.iter_decoded_messages():
            decoded.setdefault(channel.topic, []).append(msg)
    tf = decoded['/tf'][-1]
    assert len(tf.transforms) == 68 and tf.transforms[0].child_frame_id == 'jacket_r00_c00'
    q = tf.transforms[0].transform.rotation
    assert abs(q.x ** 2 + q.y ** 2 + q.z ** 2 + q.w ** 2 - 1) < 1e-9
    mesh = decoded['/jacket_cloth_node/markers'][0].markers
    assert {m.ns for m in mesh} == {'jacket', 'body', 'cloth', 'colliders', 'hood',
                                    'jacket_bones'}          # the reset's DELETEALLs
    assert {m.ns for m in mesh if m.action == 0} == {'jacket', 'body'}
    status = decoded['/diagnostics'][0].status[0]
    assert status.name == '/jacket_cloth_node: cloth simulation'
    assert 'step_cost_us_median' not in {kv.key for kv in status.values}   # no wall clock


def test_analyze_writes_the_report_charts_and_filmstrip(clip, tmp_path, capsys):
    out = tmp_path / 'analysis'
    assert main(['analyze', str(clip), '--out', str(out)]) == 0
    report = json.loads((out / 'report.json').read_text())
    for key in ('frames', 'sim_steps', 'max_vertical_strain', 'max_horizontal_strain',
                'max_penetration_m', 'max_distance_exceeded', 'nonfinite_count', 'resets'):
        assert key in report
    assert report['frames'] == 181 and report['sim_steps'] == 360
    assert report['max_vertical_strain'] < 0.5          # M12, but for the contact push-out
    assert report['nonfinite_count'] == 0 and report['resets'] == 1
    assert report['max_distance_exceeded'] > 0 and report['max_penetration_m'] > 0.001
    assert report['step_time_us']['median'] > 0
    assert report['step_time_us']['p99'] >= report['step_time_us']['median']
    assert report['replay_matches_recording'] is None   # an input-only file: nothing to compare
    for png in report['charts'] + ['filmstrip.png']:
        assert (out / png).stat().st_size > 10_000
    assert '| max vertical strain |' in (out / 'summary.md').read_text()
    # Side by side: the same session through the tethers instead of M12.
    replayed = tmp_path / 'tethers.mcap'
    assert _replay(clip, replayed, '-p', 'stretch_limit:=tethers') == 0
    both = tmp_path / 'both'
    assert main(['analyze', str(clip), str(replayed), '--compare', '--out', str(both)]) == 0
    sessions = json.loads((both / 'report.json').read_text())['sessions']
    assert [s['parameters']['stretch_limit'] for s in sessions] == ['hard_pass', 'tethers']
    assert sessions[1]['replay_matches_recording'] is True
    assert sessions[1]['max_vertical_strain'] > sessions[0]['max_vertical_strain']
    assert (both / 'filmstrip_2.png').exists()


def _foreign_joint_states(path, skeleton_names, topic='/robot/joint_states', seconds=1.0,
                          log_delay_ns=0):
    """A plain MCAP written by mcap_ros2's own writer, not ours; ``log_delay_ns``: log times
    later than the stamps (as a recorder's receive time)."""
    with open(path, 'wb') as f:
        w = Ros2Writer(f)
        schema = w.register_msgdef('sensor_msgs/msg/JointState',
                                   ros2msg_schema('sensor_msgs/msg/JointState'))
        for k in range(int(seconds * 50)):
            t = 5_000_000_000 + k * 20_000_000
            pos = [0.0] * len(skeleton_names)
            pos[skeleton_names.index('LeftShoulder_raise')] = 1.2 * np.sin(k / 10)
            w.write_message(topic, schema, {
                'header': {'stamp': {'sec': t // 10**9, 'nanosec': t % 10**9}, 'frame_id': ''},
                'name': skeleton_names, 'position': pos, 'velocity': [], 'effort': []},
                log_time=t + log_delay_ns, publish_time=t + log_delay_ns)
        w.finish()


def _node_recording(path, stamps, clip='walk', rate=60.0):
    """A session recorded by the node's rules, without DDS (ros/node.py on_joint_states): each
    JointState is written as it arrives, at its header stamp, then the pipeline's outputs.
    ``stamps``: the header stamps in arrival order; the k-th carries the clip at k / rate."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.skeleton import Skeleton
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.recording.writer import SessionRecorder
    from jacket_cloth_ros.ros.cdr import JointStateReader
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import SessionPipeline, session_topics
    texts = {}
    for name in ('character.urdf', 'jacket_rig.yaml', 'fabrics.yaml'):
        with open(shipped(name), encoding='utf-8') as f:
            texts[name] = f.read()
    skeleton = Skeleton(texts['character.urdf'])
    fabrics = load_fabrics()
    values = default_values(fabrics['tweed_jacket'])
    pipeline = SessionPipeline(skeleton, load_rig(skeleton), values)
    topics = session_topics()
    recorder = SessionRecorder(str(path), compression='lz4')
    for topic, kind, qos in topics.values():
        recorder.add_topic(topic, kind, qos)
    recorder.add_session_config(texts['character.urdf'], texts['jacket_rig.yaml'],
                                texts['fabrics.yaml'], values.by_name())
    reader = JointStateReader()
    for k, stamp in enumerate(stamps):
        names, pos = joint_state_content(skeleton.joint_names, clip, k / rate)
        msg = JointState(name=names, position=[float(p) for p in pos])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        raw = serialize_message(msg)
        recorder.write(topics['joint_states'][0], raw, stamp)
        _, outputs = pipeline.on_joint_state(reader.read(raw), stamp)
        for key, out in outputs:
            recorder.write(topics[key][0], out, stamp)
    recorder.close()
    return pipeline


def _topic_in_file_order(path, topic):
    with open(path, 'rb') as f:
        return [(m.log_time, m.data) for _, c, m in make_reader(f).iter_messages(
            log_time_order=False) if c.topic == topic]


def test_a_session_whose_stamps_go_back_replays_to_the_same_tf(tmp_path, capsys):
    # The node drops a repeated stamp and one a little back, and resets on one far back; the
    # replay must feed the inputs in the order they were recorded, not sorted by log time.
    step = 1_000_000_000 // 60
    stamps = [100 * 10 ** 9 + k * step for k in range(60)]
    stamps += [stamps[-1] - 5_000_000, stamps[-1]]                  # dropped: back, repeated
    stamps += [stamps[59] + k * step for k in range(1, 31)]
    stamps += [50 * 10 ** 9 + k * step for k in range(40)]         # far back: a reset
    live = _node_recording(tmp_path / 'live.mcap', stamps)
    assert live.dropped == 2 and live.sim.resets == 2
    out = tmp_path / 'replayed.mcap'
    assert _replay(tmp_path / 'live.mcap', out) == 0
    recorded = _topic_in_file_order(tmp_path / 'live.mcap', '/tf')
    assert len(recorded) == len(stamps) - 2
    assert _topic_in_file_order(out, '/tf') == recorded
    assert '2 dropped' in capsys.readouterr().out
    assert main(['analyze', str(tmp_path / 'live.mcap'), '--out', str(tmp_path / 'an')]) == 0
    report = json.loads((tmp_path / 'an' / 'report.json').read_text())
    assert report['replay_matches_recording'] is True
    assert report['recorded_tf_compared'] == len(recorded) and report['dropped_inputs'] == 2


def test_replay_takes_time_from_the_header_stamp_not_the_log_time(tmp_path):
    # A recorder's log time is when it received a message; the node simulates to the stamp.
    from jacket_cloth_ros.core.skeleton import Skeleton
    urdf = shipped('examples/mannequin.urdf')
    rig = shipped('examples/mannequin_rig.yaml')
    with open(urdf, encoding='utf-8') as f:
        names = list(Skeleton(f.read()).joint_names)
    late = tmp_path / 'late.mcap'
    _foreign_joint_states(late, names, log_delay_ns=54_000_000)
    out = tmp_path / 'out.mcap'
    assert main(['replay', str(late), '-o', str(out), '--urdf', urdf, '--rig', rig]) == 0
    stamps = [5_000_000_000 + k * 20_000_000 for k in range(50)]
    assert [t for t, _ in _topic_in_file_order(out, '/robot/joint_states')] == stamps
    tf = _topic_in_file_order(out, '/tf')
    assert [t for t, _ in tf] == stamps
    # The header stamp inside each /tf transform (after the CDR and sequence heads).
    assert [int.from_bytes(d[8:12], 'little') * 10 ** 9 + int.from_bytes(d[12:16], 'little')
            for _, d in tf] == stamps


def test_foreign_mcap_and_rosbag2_directory_of_another_skeleton(tmp_path):
    from jacket_cloth_ros.core.skeleton import Skeleton
    urdf = shipped('examples/mannequin.urdf')
    rig = shipped('examples/mannequin_rig.yaml')
    with open(urdf, encoding='utf-8') as f:
        names = list(Skeleton(f.read()).joint_names)
    bag = tmp_path / 'bag'
    bag.mkdir()
    _foreign_joint_states(bag / 'bag_0.mcap', names)
    (bag / 'metadata.yaml').write_text(yaml.safe_dump({'rosbag2_bagfile_information': {
        'version': 9, 'storage_identifier': 'mcap', 'relative_file_paths': ['bag_0.mcap']}}))
    out = tmp_path / 'out.mcap'
    assert main(['replay', str(bag), '-o', str(out), '--urdf', urdf, '--rig', rig]) == 0
    session = load_session(str(out))               # the replay carries its set-up
    assert session.setup.skeleton.name == 'example_mannequin'
    assert session.topic == '/robot/joint_states'
    # The .mcap file of the bag reads the same as the directory.
    assert main(['analyze', str(bag / 'bag_0.mcap'), '--out', str(tmp_path / 'an'),
                 '--urdf', urdf, '--rig', rig]) == 0
    report = json.loads((tmp_path / 'an' / 'report.json').read_text())
    assert report['frames'] == 50 and report['nonfinite_count'] == 0


def test_analyze_of_a_session_whose_every_input_is_dropped_says_so(tmp_path, capsys):
    # Every JointState non-finite: the node drops them all; the report says so, no traceback.
    path = tmp_path / 'nan.mcap'
    with open(path, 'wb') as f:
        w = Ros2Writer(f)
        schema = w.register_msgdef('sensor_msgs/msg/JointState',
                                   ros2msg_schema('sensor_msgs/msg/JointState'))
        for k in range(20):
            t = 5_000_000_000 + k * 20_000_000
            w.write_message('/joint_states', schema, {
                'header': {'stamp': {'sec': t // 10**9, 'nanosec': t % 10**9}, 'frame_id': ''},
                'name': ['spine_pitch'], 'position': [float('nan')], 'velocity': [],
                'effort': []}, log_time=t, publish_time=t)
        w.finish()
    out = tmp_path / 'an'
    capsys.readouterr()
    assert main(['analyze', str(path), '--out', str(out)]) == 0
    captured = capsys.readouterr()
    assert 'Traceback' not in captured.err
    assert '0 frames (20 of 20 inputs dropped), nothing simulated' in captured.out
    report = json.loads((out / 'report.json').read_text())
    assert (report['inputs'], report['dropped_inputs'], report['frames']) == (20, 20, 0)
    assert report['filmstrip'] is None and 'filmstrip: none' in (out / 'summary.md').read_text()


def _one_line_error(capsys, argv):
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert '\n' not in err and 'Traceback' not in err
    return err


def test_broken_files_are_one_line_errors(clip, tmp_path, capsys):
    out = str(tmp_path / 'out.mcap')
    text = tmp_path / 'notes.txt'
    text.write_text('not a recording')
    assert 'not an MCAP file' in _one_line_error(capsys, ['replay', str(text), '-o', out])
    assert 'no such file' in _one_line_error(capsys, ['replay', str(tmp_path / 'x'), '-o', out])
    # No JointState: a file with markers only.
    markers_only = tmp_path / 'markers.mcap'
    with open(markers_only, 'wb') as f:
        w = Ros2Writer(f)
        schema = w.register_msgdef('std_msgs/msg/String', 'string data')
        w.write_message('/joint_states', schema, {'data': 'hello'}, log_time=1, publish_time=1)
        w.finish()
    err = _one_line_error(capsys, ['replay', str(markers_only), '-o', out])
    assert 'no sensor_msgs/msg/JointState topic' in err and '/joint_states' in err
    err = _one_line_error(capsys, ['replay', str(markers_only), '-o', out,
                                   '--topic', '/joint_states'])
    assert "is 'std_msgs/msg/String', not sensor_msgs/msg/JointState" in err
    # Joints of another skeleton without its URDF.
    foreign = tmp_path / 'mannequin.mcap'
    _foreign_joint_states(foreign, ['LeftShoulder_raise', 'Spine_bend'])
    err = _one_line_error(capsys, ['replay', str(foreign), '-o', out])
    assert 'none of the joints' in err and '--urdf' in err
    # Bad parameter values.
    err = _one_line_error(capsys, ['replay', str(clip), '-o', out, '-p', 'sim_rate:=5'])
    assert 'sim_rate' in err and 'outside' in err
    err = _one_line_error(capsys, ['replay', str(clip), '-o', out, '-p', 'nope:=1'])
    assert 'not a parameter' in err
    # An existing output is not overwritten without --force.
    existing = tmp_path / 'existing.mcap'
    existing.write_bytes(b'keep me')
    assert 'exists' in _one_line_error(capsys, ['replay', str(clip), '-o', str(existing)])
    assert existing.read_bytes() == b'keep me'
    assert _replay(clip, existing, '--force') == 0 and existing.stat().st_size > 1000


def test_bad_bag_metadata_and_set_up_files_are_one_line_errors_naming_the_file(
        clip, tmp_path, capsys):
    out = tmp_path / 'out.mcap'
    bag = tmp_path / 'bag'
    bag.mkdir()
    shutil.copy(clip, bag / 'bag_0.mcap')
    meta = bag / 'metadata.yaml'
    for text in (b'rosbag2_bagfile_information: {storage_identifier: [mcap\n  x: 1\n',
                 b'rosbag2_bagfile_information: 5\n', b'\x89PNG\r\n\x1a\n\xff\xfe',
                 b'rosbag2_bagfile_information: {storage_identifier: mcap}\n'):
        meta.write_bytes(text)
        err = _one_line_error(capsys, ['replay', str(bag), '-o', str(out)])
        assert f'{meta}: not a rosbag2 metadata file' in err, err
    # An empty or binary URDF or rig never stands for the shipped one; errors name the file.
    empty = tmp_path / 'empty.urdf'
    empty.write_text('')
    binary = tmp_path / 'binary.yaml'
    binary.write_bytes(bytes(range(256)))
    for option, path, what in (('--urdf', empty, 'empty file'), ('--urdf', binary, 'UTF-8'),
                               ('--rig', binary, 'UTF-8')):
        for argv in (['replay', str(clip), '-o', str(out)],
                     ['analyze', str(clip), '--out', str(tmp_path / 'an')]):
            err = _one_line_error(capsys, argv + [option, str(path)])
            assert str(path) in err and what in err, err
    assert not out.exists()
    err = _one_line_error(capsys, ['motion', '--urdf', str(empty), '-o', str(out)])
    assert f'URDF {empty}: empty file' in err
    err = _one_line_error(capsys, ['picture', str(clip), '-o', str(tmp_path / 'p.png'),
                                   '--rig', str(binary)])
    assert str(binary) in err and 'UTF-8' in err


def test_truncated_recording_gives_its_readable_part_with_a_warning(clip, tmp_path, capsys):
    full = tmp_path / 'full.mcap'
    assert _replay(clip, full) == 0
    data = full.read_bytes()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:int(len(data) * 0.6)])
    out = tmp_path / 'out.mcap'
    capsys.readouterr()
    assert main(['replay', str(cut), '-o', str(out)]) == 0
    captured = capsys.readouterr()
    assert 'cut short' in captured.err
    n = int(captured.out.split(': ')[1].split(' JointState')[0])
    assert 0 < n < 181


def _flip_in_first_chunk(src, dst, cut=None):
    """A copy of ``src`` with one byte flipped in its first chunk's data where the chunk still
    decompresses (only its CRC tells), optionally cut short."""
    import dataclasses
    from mcap.records import Chunk
    from mcap.stream_reader import get_chunk_data_stream
    data = bytearray(src.read_bytes())
    with open(src, 'rb') as f:
        index = make_reader(f).get_summary().chunk_indexes[0]
    f = io.BytesIO(bytes(data[index.chunk_start_offset + 9:]))
    chunk = Chunk.read(ReadDataStream(f))
    start = index.chunk_start_offset + 9 + f.tell() - len(chunk.data)
    for k in range(len(chunk.data) // 2, len(chunk.data)):
        flipped = bytearray(chunk.data)
        flipped[k] ^= 0x20
        try:
            get_chunk_data_stream(dataclasses.replace(chunk, data=bytes(flipped)))
        except Exception:  # noqa: BLE001 - a flip the codec notices: try the next byte
            continue
        data[start + k] ^= 0x20
        break
    dst.write_bytes(bytes(data[:cut]))


@pytest.mark.parametrize('compression', ['none', 'lz4'])
def test_a_damaged_chunk_is_an_error_naming_the_file_and_nothing_is_replayed(
        clip, tmp_path, capsys, compression):
    full = tmp_path / 'full.mcap'
    assert _replay(clip, full, '-p', f'record_compression:={compression}') == 0
    flipped = tmp_path / 'flipped.mcap'
    _flip_in_first_chunk(full, flipped)
    assert flipped.read_bytes() != full.read_bytes()
    out = tmp_path / 'out.mcap'
    capsys.readouterr()
    err = _one_line_error(capsys, ['replay', str(flipped), '-o', str(out)])
    assert err.startswith(f'jacket_cloth replay: {flipped}: damaged file') and 'CRC' in err
    assert not out.exists() and not list(tmp_path.glob('.out.mcap.*'))
    assert 'damaged file' in _one_line_error(capsys, ['analyze', str(flipped), '--out',
                                                      str(tmp_path / 'an')])
    # Cut short as well (no summary: the records are streamed): still damage, not a cut.
    both = tmp_path / 'flipped_and_cut.mcap'
    _flip_in_first_chunk(full, both, cut=len(full.read_bytes()) * 3 // 4)
    assert 'damaged file' in _one_line_error(capsys, ['replay', str(both), '-o', str(out)])


def test_a_partial_output_never_replaces_the_file(clip, tmp_path, capsys, monkeypatch):
    from jacket_cloth_ros.tools import replay as replay_module
    out = tmp_path / 'out.mcap'

    def boom(*args, **kwargs):
        raise OSError('disk full')
    monkeypatch.setattr(replay_module, 'run_session', boom)
    assert 'disk full' in _one_line_error(capsys, ['replay', str(clip), '-o', str(out)])
    assert not out.exists() and not list(tmp_path.glob('.out.mcap.*'))
    shutil.rmtree(tmp_path, ignore_errors=True)


def test_byte_templates_equal_the_field_by_field_encoding(make_sim):
    # /tf and the markers go out from byte templates laid out once; the field-by-field CDR
    # writer is the reference that rclpy and mcap_ros2 decode (tests above). Equal bytes, in
    # two states of a walk, with and without the DELETEALLs of a reset.
    from conftest import play
    from jacket_cloth_ros.ros import cdr, messages
    sim = make_sim()
    for seconds, stamp in ((0.3, 10 ** 10 + 7), (0.5, 2 * 10 ** 10 + 999_999_999)):
        play(sim, 'walk', 60, seconds)
        bones = sim.bones()
        # The prefix on every frame, parents too (as robot_state_publisher's).
        assert messages.tf_message(bones, stamp, 'p/') == cdr.tf_message(
            bones.names, ['p/' + p for p in bones.parents], bones.translations,
            bones.quaternions, stamp, 'p/')
        for reset, debug in ((True, False), (False, False), (True, True), (False, True)):
            specs = messages.marker_specs(sim, reset, debug)
            assert messages.marker_array(sim, stamp, 'base_link', reset, debug) == \
                cdr.marker_array(specs, stamp, 'base_link')


def test_a_live_frame_prefix_change_renames_the_bones_on_the_next_tf(make_sim):
    # The pipeline holds its /tf layout; a frame_prefix change must lay it out again.
    from rclpy.serialization import deserialize_message
    from tf2_msgs.msg import TFMessage
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.ros.cdr import JointStateContent
    sim = make_sim()
    fabrics = load_fabrics()
    pipe = SessionPipeline(sim.skeleton, sim.rig, default_values(fabrics['tweed_jacket']))
    names, pos = joint_state_content(sim.skeleton.joint_names, 'walk', 0.0)
    frames = []
    for k, prefix in enumerate(('', 'left/')):
        pipe.apply(pipe.values.with_changes({'frame_prefix': prefix}))
        stamp = 10 ** 9 + k * 10 ** 7
        _, outputs = pipe.on_joint_state(JointStateContent(stamp, names, pos), stamp)
        frames.append(deserialize_message(dict(outputs)['tf'], TFMessage).transforms[0])
    assert [f.child_frame_id for f in frames] == ['jacket_r00_c00', 'left/jacket_r00_c00']
    assert [f.header.frame_id for f in frames] == ['base_link', 'left/base_link']


def test_two_sources_on_different_clocks_keep_the_output_rates(make_sim):
    # Stamps jumping back and forth beyond reset_gap sent markers and diagnostics on every
    # input (issue 38): each clock keeps its own grid, at the rates set.
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros.values import default_values
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.ros.cdr import JointStateContent
    sim = make_sim()
    fabrics = load_fabrics()
    pipe = SessionPipeline(sim.skeleton, sim.rig, default_values(fabrics['tweed_jacket']))
    counts = {'tf': 0, 'markers': 0, 'diagnostics': 0}
    for k in range(120):                    # 2 s of each clock, at 60 Hz, interleaved
        names, pos = joint_state_content(sim.skeleton.joint_names, 'walk', k / 60)
        for start in (1000 * 10 ** 9, 10 * 10 ** 9):
            stamp = start + k * 10 ** 9 // 60
            _, outputs = pipe.on_joint_state(JointStateContent(stamp, names, pos), stamp)
            for key, _ in outputs:
                counts[key] += 1
    assert counts['tf'] == 240
    assert counts['markers'] <= 2 * (2 * 30 + 1), counts      # 30 Hz on each clock
    assert counts['diagnostics'] <= 2 * (2 * 1 + 1), counts   # 1 Hz on each clock


def test_background_writer_makes_the_same_file_and_reports_its_errors(clip, tmp_path):
    # The replay writes through a thread: same records in the same order, so the same bytes.
    from jacket_cloth_ros.recording.writer import SessionRecorder
    session = load_session(str(clip))
    files = []
    for background in (False, True):
        path = tmp_path / f'bg_{background}.mcap'
        rec = SessionRecorder(str(path), final_name='session.mcap', background=background)
        rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState')
        for stamp, _, kind, data in session.events:
            rec.write('/joint_states', data, stamp)
        rec.close()
        files.append(path.read_bytes())
    assert files[0] == files[1] and len(files[0]) > 10_000
    broken = SessionRecorder(str(tmp_path / 'broken.mcap'), background=True)
    broken.add_topic('/joint_states', 'sensor_msgs/msg/JointState')
    broken._writer._compress = lambda raw: 1 / 0      # a codec failing in the writer thread
    with pytest.raises(ZeroDivisionError):      # at a later write or at the close, by timing
        try:
            for k in range(30):                         # three chunks (flushed once a second)
                broken.write('/joint_states', b'\0' * 100, k * 10 ** 8)
        finally:
            broken.close()


def test_a_new_pipeline_has_loaded_every_kernel_its_inputs_use():
    # In a fresh interpreter: loading a compiled kernel on the first inputs took 76 and 41 ms,
    # more than a step; the pipeline loads them at start, so nothing is left to load later.
    import subprocess
    import sys
    script = '''
from numba.core.registry import CPUDispatcher
from jacket_cloth_ros.core.physics import cloth, colliders, hood, pose, sampling, step
from jacket_cloth_ros.core import measures
from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.ros import cdr, marker_kernel
from jacket_cloth_ros.ros.values import default_values
from jacket_cloth_ros.ros.pipeline import SessionPipeline
from jacket_cloth_ros.motion.messages import clip_messages
sk = Skeleton(open(shipped('character.urdf')).read())
fabrics = load_fabrics()
pipe = SessionPipeline(sk, load_rig(sk), default_values(fabrics['tweed_jacket']))
modules = (cloth, colliders, hood, pose, sampling, step, cdr, marker_kernel, measures)
def loaded():
    return {(m.__name__, n) for m in modules for n, f in vars(m).items()
            if isinstance(f, CPUDispatcher) and f.signatures}
before = loaded()
for stamp, msg in clip_messages(sk, 'walk', 120.0, 0.5, 10 ** 10):
    pipe.on_joint_state(msg, stamp)
print(sorted(loaded() - before))
'''
    out = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == '[]', out


def test_outputs_are_regular_files_and_never_an_input_even_with_force(clip, tmp_path, capsys):
    import stat
    src = tmp_path / 'in.mcap'
    shutil.copy(clip, src)
    kept = src.read_bytes()
    link = tmp_path / 'link.mcap'
    link.symlink_to(src)
    hard = tmp_path / 'hard.mcap'
    os.link(src, hard)
    for out in (src, link, hard):
        err = _one_line_error(capsys, ['replay', str(src), '-o', str(out), '--force'])
        assert f'{out} is the input {src}' in err, err
    err = _one_line_error(capsys, ['picture', str(src), '-o', str(src), '--force'])
    assert 'is the input' in err
    urdf = tmp_path / 'character.urdf'
    shutil.copy(shipped('character.urdf'), urdf)
    err = _one_line_error(capsys, ['motion', '--urdf', str(urdf), '-o', str(urdf), '--force'])
    assert 'is the input' in err
    assert src.read_bytes() == kept and urdf.read_text() == open(shipped('character.urdf')).read()
    # A pipe (as a device: /dev/full was replaced by a regular file) or a folder is refused.
    fifo = tmp_path / 'fifo'
    os.mkfifo(fifo)
    folder = tmp_path / 'folder'
    folder.mkdir()
    for out in (fifo, folder):
        for argv in (['replay', str(src), '-o', str(out), '--force'],
                     ['motion', '-o', str(out), '--force'],
                     ['picture', str(src), '-o', str(out), '--force']):
            assert 'not a regular file' in _one_line_error(capsys, argv)
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and folder.is_dir()
    # analyze --out: a folder, not an input's, and its files regular files.
    err = _one_line_error(capsys, ['analyze', str(src), '--out', str(src), '--force'])
    assert f'{src} is not a folder' in err
    bag = tmp_path / 'bag'
    bag.mkdir()
    shutil.copy(clip, bag / 'bag_0.mcap')
    err = _one_line_error(capsys, ['analyze', str(bag), '--out', str(bag), '--force'])
    assert f'{bag} is the input {bag}' in err
    err = _one_line_error(capsys, ['analyze', str(bag), '--out', str(bag / 'an')])
    assert 'inside the input folder' in err
    err = _one_line_error(capsys, ['replay', str(bag), '-o', str(bag / 'out.mcap')])
    assert 'inside the input folder' in err
    assert os.listdir(bag) == ['bag_0.mcap']
    an = tmp_path / 'an'
    an.mkdir()
    os.mkfifo(an / 'strain.png')
    err = _one_line_error(capsys, ['analyze', str(src), '--out', str(an), '--force'])
    assert 'strain.png is not a regular file' in err


def test_a_forced_output_is_replaced_only_by_a_complete_file(clip, tmp_path, capsys,
                                                             monkeypatch):
    from jacket_cloth_ros.tools import cli
    out = tmp_path / 'walk.mcap'
    out.write_bytes(b'keep me')

    def boom(*args, **kwargs):
        raise OSError('disk full')
        yield
    monkeypatch.setattr(cli, 'clip_messages', boom)
    assert 'disk full' in _one_line_error(capsys, ['motion', '-o', str(out), '--force'])
    assert out.read_bytes() == b'keep me' and os.listdir(tmp_path) == ['walk.mcap']
    monkeypatch.undo()
    assert main(['motion', '--duration', '1', '-o', str(out), '--force']) == 0
    assert out.stat().st_size > 1000 and os.listdir(tmp_path) == ['walk.mcap']
    assert out.stat().st_mode & 0o777 == 0o666 & ~_umask()


def _umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_overrides_read_numbers_as_numbers_and_name_unknown_presets(clip, tmp_path, capsys):
    out = tmp_path / 'out.mcap'
    # YAML 1.1 reads 1e3 as a string; for a float parameter it is the number it says.
    assert _replay(clip, out, '-p', 'sim_rate:=1e3', '-p', 'wind:=[1e1, 0, -2.5E0]') == 0
    err = _one_line_error(capsys, ['replay', str(clip), '-o', str(out), '--force',
                                   '-p', 'sim_rate:=abc'])
    assert 'sim_rate' in err and 'not a float' in err
    err = _one_line_error(capsys, ['replay', str(clip), '-o', str(out), '--force',
                                   '-p', 'sim_rate:=nan'])
    assert 'sim_rate' in err
    err = _one_line_error(capsys, ['replay', str(clip), '-o', str(out), '--force',
                                   '-p', 'fabric_preset:=bogus'])
    assert "'bogus' is not a preset" in err and 'tweed_jacket' in err
    err = _one_line_error(capsys, ['replay', str(clip), '-o', str(out), '--force',
                                   '-p', 'fabric:=veil'])
    assert 'renamed fabric_preset' in err
    # A preset named with -p seeds the fabric.* values, as --fabric does.
    session = load_session(str(clip), overrides=['fabric_preset:=veil'])
    veil = session.setup.fabrics['veil']
    assert session.setup.values.fabric.damping == veil.damping
    session = load_session(str(clip), overrides=['fabric_preset:=veil', 'fabric.damping:=0.3'])
    assert session.setup.values.fabric.damping == 0.3


def test_diagnosticsquantiles_are_numpys_on_lists_of_any_length():
    # Diagnostics sort a list instead of calling numpy (a crowd sends 64 a second): the step
    # cost median and latency p99 they report must stay numpy's linear interpolation.
    from jacket_cloth_ros.ros.pipeline import quantile
    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 10, 101, 120, 400):
        values = sorted(int(v) for v in rng.integers(0, 10 ** 9, n))
        assert quantile(values, 0.5) == pytest.approx(np.median(values), rel=1e-12)
        assert quantile(values, 0.99) == pytest.approx(np.percentile(values, 99), rel=1e-12)


def test_a_session_is_read_without_its_outputs_and_its_tf_compared_by_digest(tmp_path):
    # Issue 38 item 19: replay and analyze held a whole recording (markers and /tf, most of
    # its bytes) in memory; only what the simulation is fed is read now.
    from jacket_cloth_ros.recording.reader import message_digest
    from jacket_cloth_ros.tools.analyze import SessionFigures
    from jacket_cloth_ros.tools.session import load_session
    clip, session = tmp_path / 'walk.mcap', tmp_path / 'session.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '1', '-o', str(clip)]) == 0
    assert main(['replay', str(clip), '-o', str(session)]) == 0
    loaded = load_session(str(session))
    assert {m.topic for m in loaded.recording.messages} == {'/joint_states'}
    tf = [m.data for m in read_messages(str(session))[0] if m.topic == '/tf']
    figures = SessionFigures(loaded, 2)
    assert figures.recorded_tf == [message_digest(d) for d in tf] and len(tf) > 30


def test_picture_draws_the_character_and_rig_recorded_in_it(tmp_path, capsys, monkeypatch):
    # Issue 47 item 5: `picture` of a recording made with another character drew the shipped
    # skeleton beside that character's cloth (exit 0); analyze read the recorded ones.
    from jacket_cloth_ros.core.skeleton import Skeleton
    from jacket_cloth_ros.tools import picture
    urdf = shipped('examples/mannequin.urdf')
    rig = shipped('examples/mannequin_rig.yaml')
    with open(urdf, encoding='utf-8') as f:
        names = list(Skeleton(f.read()).joint_names)
    inputs, out = tmp_path / 'inputs.mcap', tmp_path / 'out.mcap'
    _foreign_joint_states(inputs, names)
    assert main(['replay', str(inputs), '-o', str(out), '--urdf', urdf, '--rig', rig]) == 0
    drawn = []
    monkeypatch.setattr(picture, 'draw_filmstrip',
                        lambda frames, skeleton, *a, **k: drawn.append((frames, skeleton)))
    assert main(['picture', str(out), '-o', str(tmp_path / 'p.png'), '--moments', '2']) == 0
    [(frames, skeleton)] = drawn
    assert skeleton.name == 'example_mannequin'
    assert all(len(f.links) == len(skeleton.link_names) for f in frames)
    # A recording of inputs alone records no character: one line, never the shipped one.
    capsys.readouterr()
    err = _one_line_error(capsys, ['picture', str(inputs), '-o', str(tmp_path / 'q.png')])
    assert 'no character recorded in it' in err and '--urdf' in err
