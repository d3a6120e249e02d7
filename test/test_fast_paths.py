# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The hand-written fast paths held to the libraries they stand in for (issue 49 item 4).

What the node publishes and records (cdr.py's templates and encoders, from a real simulation
through SessionPipeline) against rclpy's ``serialize_message`` of the same content built as
message objects field by field; the recorder's MCAP files (mcap_file.McapWriter) against the
mcap package's own ``Writer`` given the same records, both read back by mcap's readers with
their CRCs checked.
"""

import io
import json
import struct
import zlib

import numpy as np
import pytest
import yaml
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, Quaternion, TransformStamped, Vector3
from mcap.reader import NonSeekingReader, make_reader
from mcap.writer import CompressionType, Writer
from rcl_interfaces.msg import Parameter, ParameterEvent, ParameterType, ParameterValue
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.jacket_mesh import posed_joints
from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.recording.definitions import ros2msg_schema
from jacket_cloth_ros.recording.writer import SessionRecorder
from jacket_cloth_ros.ros import cdr, messages
from jacket_cloth_ros.ros.cdr_bounds import _Walker
from jacket_cloth_ros.ros.values import default_values
from jacket_cloth_ros.ros.pipeline import SessionPipeline, session_topics

# Seconds that need 31 bits and nanoseconds that are not round: a stamp split wrongly shows.
START_NS = 1_700_000_000 * 10**9 + 123_456_789


class _Layout(_Walker):
    """cdr_bounds' walk of a message's fields by its rosidl type, noting the alignment padding."""

    def __init__(self, raw):
        super().__init__(raw, '<')
        self.padding = []

    def take(self, size, align):
        pad = -(self.at - 4) % align
        self.padding.extend(range(self.at, self.at + pad))
        super().take(size, align)


def assert_same_cdr(mine: bytes, reference: object) -> None:
    """Assert that ``mine`` is rclpy's serialisation of the message ``reference``.

    Byte for byte but in two places where rclpy (Fast CDR) leaves its buffer as it found it,
    uninitialised, so that two serialisations of one message can differ: the alignment
    padding, and bytes after the message's end (JointState, ParameterEvent). Both places come
    from walking rclpy's own bytes by the rosidl type description, not from the encoder under
    test: ours must end where the message does and hold zeros in its padding.
    """
    kind = type(reference)
    ref = serialize_message(reference)
    layout = _Layout(ref)
    layout.message(kind)
    assert len(mine) == layout.at, f'{len(mine)} bytes, the message has {layout.at}'
    ours = np.frombuffer(mine, dtype=np.uint8)
    theirs = np.frombuffer(ref, dtype=np.uint8, count=layout.at)
    padding = np.zeros(layout.at, dtype=bool)
    padding[layout.padding] = True
    assert not ours[padding].any(), 'padding not zeroed'
    differ = np.flatnonzero((ours != theirs) & ~padding)
    assert not differ.size, (f'{differ.size} bytes differ from rclpy\'s, the first at '
                             f'{differ[0]}: {mine[differ[0]:differ[0] + 8].hex()} for '
                             f'{ref[differ[0]:differ[0] + 8].hex()}')
    assert deserialize_message(mine, kind) == deserialize_message(ref, kind)


def _time(stamp_ns):
    return Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)


def _pipeline(skeleton, rig, timing=True, node_name='/jacket_cloth_node', **values):
    fabrics = load_fabrics()
    return SessionPipeline(skeleton, rig,
                           default_values(fabrics['tweed_jacket']).with_changes(values),
                           node_name, timing)


def _inputs(pipe, count, clip='walk', rate=60):
    """Feed a clip's JointStates; yields (stamp, JointState bytes, outputs) of each input.

    The simulation is the input's until the next one is asked for.
    """
    reader = cdr.JointStateReader()
    for k in range(count):
        names, pos = joint_state_content(pipe.sim.skeleton.joint_names, clip, k / rate)
        stamp = START_NS + k * 10**9 // rate
        raw = cdr.joint_state(stamp, names, pos)
        _, outputs = pipe.on_joint_state(reader.read(raw), stamp)
        yield stamp, raw, outputs


def _transform(parent, child, pose, stamp_ns):
    t = TransformStamped(child_frame_id=child)
    t.header.stamp, t.header.frame_id = _time(stamp_ns), parent
    x, y, z, qx, qy, qz, qw = (float(v) for v in pose)
    t.transform.translation = Vector3(x=x, y=y, z=z)
    t.transform.rotation = Quaternion(x=qx, y=qy, z=qz, w=qw)
    return t


# -- /tf ---------------------------------------------------------------------------------------

@pytest.mark.parametrize('values', [
    {}, {'frame_prefix': 'npc1/', 'publish_world_tf': True, 'world_frame': 'map'}],
    ids=['bones', 'prefixed_with_world'])
def test_tf_bytes_are_rclpys_tf_message_of_the_bones(skeleton, rig, values):
    pipe = _pipeline(skeleton, rig, **values)
    prefix = values.get('frame_prefix', '')
    for stamp, _, outputs in _inputs(pipe, 8):
        tfs = [data for key, data in outputs if key == 'tf']
        assert len(tfs) == (2 if values.get('publish_world_tf') else 1)
        bones = pipe.sim.bones()
        assert len(bones.names) > 50 and bones.finite
        reference = TFMessage(transforms=[
            _transform(prefix + parent, prefix + name, pose, stamp)
            for name, parent, pose in zip(bones.names, bones.parents, bones.poses)])
        assert_same_cdr(tfs[0], reference)
        if len(tfs) == 2:           # world_frame -> the root: the input's own pose
            last = pipe.sim.last
            world = _transform('map', prefix + skeleton.link_names[0],
                               np.concatenate([last.root[:3, 3], last.root_quat]), stamp)
            assert_same_cdr(tfs[1], TFMessage(transforms=[world]))


# -- markers ----------------------------------------------------------------------------------

def _marker_reference(specs, frame, stamp_ns):
    """Return the MarkerArray of ``specs`` (messages.MarkerSpec) built as rclpy messages."""
    out = MarkerArray()
    for s in specs:
        m = Marker(ns=s.ns, id=s.id, type=s.type, action=s.action, frame_locked=False,
                   lifetime=Duration(sec=s.lifetime_s, nanosec=0))
        m.header.stamp, m.header.frame_id = _time(stamp_ns), frame
        x, y, z = (float(v) for v in s.position)
        qx, qy, qz, qw = (float(v) for v in s.orientation)
        m.pose.position, m.pose.orientation = Point(x=x, y=y, z=z), Quaternion(
            x=qx, y=qy, z=qz, w=qw)
        sx, sy, sz = (float(v) for v in s.scale)
        m.scale = Vector3(x=sx, y=sy, z=sz)
        r, g, b, a = (float(v) for v in s.color)      # float64 here: rclpy rounds to float32
        m.color = ColorRGBA(r=r, g=g, b=b, a=a)
        if s.points is not None:
            m.points = [Point(x=x, y=y, z=z) for x, y, z in np.asarray(s.points).tolist()]
        if s.colors is not None:
            m.colors = [ColorRGBA(r=r, g=g, b=b, a=a)
                        for r, g, b, a in np.asarray(s.colors).tolist()]
        out.markers.append(m)
    return out


@pytest.mark.parametrize('debug,body,prefix', [
    (False, 'on', ''), (False, 'off', ''), (True, 'on', 'npc1/'), (True, 'off', '')],
    ids=['default', 'without_body', 'debug_prefixed', 'debug_without_body'])
def test_marker_bytes_are_rclpys_marker_array_of_the_simulation(skeleton, rig, debug, body,
                                                                prefix):
    pipe = _pipeline(skeleton, rig, markers_debug=debug, markers_body=body,
                     frame_prefix=prefix)
    frame = prefix + skeleton.link_names[0]
    sent = 0
    for stamp, _, outputs in _inputs(pipe, 9):
        for key, data in outputs:
            if key != 'markers':
                continue
            reset = sent == 0               # the first array clears each namespace first
            specs = messages.marker_specs(pipe.sim, reset=reset, debug=debug,
                                          body=body == 'on')
            assert_same_cdr(data, _marker_reference(specs, frame, stamp))
            _check_marker_content(pipe, deserialize_message(data, MarkerArray), specs,
                                  reset, debug, body == 'on', frame, stamp)
            sent += 1
    assert sent == 5                        # 30 Hz of 60 Hz inputs


def _check_marker_content(pipe, got, specs, reset, debug, body, frame, stamp):
    """What the bytes say, beyond being rclpy's: the values a viewer takes from them."""
    clears = [m.ns for m in got.markers if m.action == messages.DELETEALL]
    assert clears == (list(messages.MARKER_NAMESPACES) if reset else [])
    shown = {m.ns for m in got.markers if m.action == messages.ADD}
    assert shown == ({'jacket'} | ({'body'} if body else set())
                     | (set(messages.DEBUG_NAMESPACES) if debug else set()))
    for m, s in zip(got.markers, specs, strict=True):
        assert m.header.frame_id == frame and m.header.stamp == _time(stamp)
        assert m.lifetime == Duration(sec=0 if m.action == messages.DELETEALL else 1)
        # float32 colours (rounded once, as rclpy rounds), float64 points (not rounded).
        assert [m.color.r, m.color.g, m.color.b, m.color.a] == \
            np.float32(s.color).tolist()
        if s.points is not None:
            assert np.array_equal([[p.x, p.y, p.z] for p in m.points], s.points)
    ids = [(m.ns, m.id) for m in got.markers if m.action != messages.DELETEALL]
    assert len(set(ids)) == len(ids)
    # The jacket mesh the fast path skins, poses and shades in one compiled call, against
    # the separate calls that pictures and export use: their outer faces, in their order (the
    # viewers draw both sides of a triangle list, so the live markers carry no lining).
    jacket = next(m for m in got.markers if m.ns == 'jacket' and m.action == messages.ADD)
    outfit = messages.outfit(pipe.sim.rig)
    sim = pipe.sim
    points, colors = outfit.triangles('jacket', posed_joints(
        sim.links, outfit.bone_parents, sim.bones().poses))
    outer = np.repeat(~outfit.jacket.back, 3)
    assert 0 < outer.sum() < len(points)
    points, colors = points[outer], colors[outer]
    assert len(jacket.points) == len(points) > 1000 and len(jacket.colors) == len(points)
    got_points = np.array([[p.x, p.y, p.z] for p in jacket.points])
    assert np.abs(got_points - points).max() < 1e-12       # float64, not rounded to float32
    assert np.array_equal([[c.r, c.g, c.b, c.a] for c in jacket.colors], colors)


# -- diagnostics ------------------------------------------------------------------------------

def _status(level, name, message, values):
    return DiagnosticStatus(level=bytes([level]), name=name, message=message,
                            hardware_id='jacket_cloth',
                            values=[KeyValue(key=k, value=str(v)) for k, v in values])


def test_diagnostics_bytes_are_rclpys_diagnostic_array_of_the_pipeline(skeleton, rig):
    node = '/npc1/jacket_cloth_node'
    pipe = _pipeline(skeleton, rig, timing=False, node_name=node, diagnostics_rate=10.0,
                     record='/tmp/odd name é.mcap')
    sent = 0
    for stamp, _, outputs in _inputs(pipe, 20):
        for key, data in outputs:
            if key != 'diagnostics':
                continue
            sim = pipe.sim
            vertical, horizontal = sim.strain()
            values = [     # docs/node.md's keys, in the order the node sends them
                ('overruns', sim.faults.overruns), ('resets', sim.resets),
                ('nonfinite_inputs', sim.faults.nonfinite), ('last_reset', 'first sample'),
                ('worst_vertical_strain', f'{vertical:.4f}'),
                ('worst_horizontal_strain', f'{horizontal:.4f}'),
                ('inputs', pipe.inputs), ('dropped_inputs', 0), ('undecodable_inputs', 0),
                ('lost_inputs', 0), ('sim_steps', sim.steps_total), ('retried_steps', 0),
                ('lod_level', sim.lod.level), ('viewer_distance_m', ''),
                ('recording', '/tmp/odd name é.mcap')]
            reference = DiagnosticArray(status=[_status(
                messages.OK, f'{node}: cloth simulation', 'ok', values)])
            reference.header.stamp = _time(stamp)
            assert_same_cdr(data, reference)
            sent += 1
    assert sent == 4 and pipe.inputs == 20 and pipe.sim.steps_total > 20


def test_diagnostic_array_encoder_is_rclpys_for_every_level_and_odd_text():
    # Strings of every length modulo 4 (padding), UTF-8 beyond one byte a character, empty
    # values, several statuses, each level.
    statuses = [
        (messages.OK, '/a: cloth simulation', 'ok', 'jacket_cloth', {'k': 1, 'kk': 2.5}),
        (messages.WARN, 'é', '3 reset(s), the last: jump — 0.4 m', 'hw', {}),
        (messages.ERROR, '', 'every input dropped', '', {'': '', 'abc': 'ü' * 5}),
    ]
    for stamp in (0, START_NS, 2**31 * 10**9 - 1):
        reference = DiagnosticArray(status=[
            DiagnosticStatus(level=bytes([level]), name=name, message=message,
                             hardware_id=hw, values=[KeyValue(key=k, value=str(v))
                                                     for k, v in values.items()])
            for level, name, message, hw, values in statuses])
        reference.header.stamp = _time(stamp)
        assert_same_cdr(cdr.diagnostic_array(stamp, statuses), reference)


# -- what else is recorded: JointState, parameter events -----------------------------------

@pytest.mark.parametrize('names,frame', [
    (['hip', 'knee_left', 'a', 'world_joint/rot_w'], 'odd'), ([], ''), (['q'], 'base_link')])
def test_joint_state_encoder_is_rclpys(names, frame):
    positions = [0.1 * k - 1e-300 for k in range(len(names))]
    reference = JointState(name=names, position=positions)
    reference.header.stamp, reference.header.frame_id = _time(START_NS), frame
    assert_same_cdr(cdr.joint_state(START_NS, names, positions, frame), reference)


def test_parameter_event_encoder_is_rclpys_for_every_value_type():
    T = ParameterType
    changed = [
        Parameter(name='sim_rate', value=ParameterValue(type=T.PARAMETER_DOUBLE,
                                                        double_value=120.5)),
        Parameter(name='b', value=ParameterValue(type=T.PARAMETER_BOOL, bool_value=True)),
        Parameter(name='iterations', value=ParameterValue(type=T.PARAMETER_INTEGER,
                                                          integer_value=-7)),
        Parameter(name='record', value=ParameterValue(type=T.PARAMETER_STRING,
                                                      string_value='/tmp/é.mcap')),
        Parameter(name='bytes', value=ParameterValue(type=T.PARAMETER_BYTE_ARRAY,
                                                     byte_array_value=[b'\x01', b'\xff'])),
        Parameter(name='bools', value=ParameterValue(type=T.PARAMETER_BOOL_ARRAY,
                                                     bool_array_value=[True, False, True])),
        Parameter(name='ints', value=ParameterValue(type=T.PARAMETER_INTEGER_ARRAY,
                                                    integer_array_value=[1, -2, 2**40])),
        Parameter(name='doubles', value=ParameterValue(type=T.PARAMETER_DOUBLE_ARRAY,
                                                       double_array_value=[0.5, 1e-300])),
        Parameter(name='wind', value=ParameterValue(type=T.PARAMETER_STRING_ARRAY,
                                                    string_array_value=['x', 'yz', ''])),
    ]
    reference = ParameterEvent(stamp=_time(START_NS), node='/npc1/jacket_cloth_node',
                               changed_parameters=changed)
    assert_same_cdr(cdr.parameter_event(START_NS, '/npc1/jacket_cloth_node', changed),
                    reference)


# -- MCAP -------------------------------------------------------------------------------------

def _session(skeleton, rig):
    """Return a short real session's records: (topic, CDR bytes, stamp) in the node's order."""
    topics = session_topics()
    pipe = _pipeline(skeleton, rig, diagnostics_rate=5.0)
    out = []
    for stamp, raw, outputs in _inputs(pipe, 40, rate=50):
        out.append((topics['joint_states'][0], raw, stamp))
        out.extend((topics[key][0], data, stamp) for key, data in outputs)
    # A parameter change between two inputs, as the node records it.
    changed = [Parameter(name='markers_debug', value=ParameterValue(
        type=ParameterType.PARAMETER_BOOL, bool_value=True))]
    out.insert(len(out) // 2, ('/parameter_events', cdr.parameter_event(
        out[len(out) // 2][2], '/jacket_cloth_node', changed), out[len(out) // 2][2]))
    return topics, out


@pytest.fixture(scope='module')
def session(skeleton, rig):
    return _session(skeleton, rig)


CODECS = {'none': CompressionType.NONE, 'lz4': CompressionType.LZ4,
          'zstd': CompressionType.ZSTD}


def _set_up(path):
    """Return the metadata records a session's recorder writes before its messages."""
    return [('jacket_cloth_session', {
        'urdf': '<robot/>', 'rig_yaml': 'rig: 1', 'fabrics_yaml': 'fabrics: 2',
        'parameters_json': json.dumps({'record': str(path)}), 'node_name': '/jacket_cloth_node'}),
        ('extra', {'k': 'v', 'é': ''})]


def _recorded(path, topics, records, compression):
    """Write the session with the project's recorder (SessionRecorder, McapWriter)."""
    recorder = SessionRecorder(str(path), flush_period_ns=200_000_000, compression=compression)
    for topic, kind, qos in topics.values():
        recorder.add_topic(topic, kind, qos)
    recorder.add_session_config('<robot/>', 'rig: 1', 'fabrics: 2', {'record': str(path)},
                                node_name='/jacket_cloth_node')
    recorder.add_metadata('extra', {'k': 'v', 'é': ''})
    for topic, data, stamp in records:
        recorder.write(topic, data, stamp)
    recorder.close()
    with open(path, 'rb') as f:
        return f.read()


def _reference(path, rosbag2, topics, records, compression):
    """Write the same records with mcap's own Writer: profile, schemas, channels, metadata.

    ``rosbag2``: the metadata record the recorder closes its file with (its text is the bag's
    description, checked apart).
    """
    out = io.BytesIO()
    writer = Writer(out, chunk_size=64 * 1024, compression=CODECS[compression],
                    enable_crcs=True, enable_data_crcs=True)
    writer.start(profile='ros2', library='jacket_cloth_ros')
    schemas, channels, sequences = {}, {}, {}
    for topic, kind, qos in topics.values():
        if kind not in schemas:
            schemas[kind] = writer.register_schema(kind, 'ros2msg',
                                                   ros2msg_schema(kind).encode())
        channels[topic] = writer.register_channel(
            topic, 'cdr', schemas[kind], {'offered_qos_profiles': qos, 'topic_type_hash': ''})
        sequences[topic] = 0
    for name, data in _set_up(path):
        writer.add_metadata(name, data)
    for topic, data, stamp in records:
        writer.add_message(channels[topic], stamp, data, stamp, sequences[topic])
        sequences[topic] += 1
    writer.add_metadata('rosbag2', rosbag2)
    writer.finish()
    return out.getvalue()


def _read(data):
    """Return all that mcap's reader makes of a file, CRCs checked; chunk_count aside."""
    reader = make_reader(io.BytesIO(data), validate_crcs=True)
    summary = reader.get_summary()
    header = reader.get_header()
    stats = summary.statistics
    assert stats.chunk_count == len(summary.chunk_indexes) > 0
    messages_read = [(c.topic, s.name, m.sequence, m.log_time, m.publish_time, m.data)
                     for s, c, m in reader.iter_messages(log_time_order=False)]
    in_time_order = [(c.topic, m.log_time, m.data)
                     for _, c, m in reader.iter_messages(log_time_order=True)]
    # The non-seeking reader reads every record and checks the data section's CRC as well.
    streamed = [(c.topic, s.name, m.sequence, m.log_time, m.publish_time, m.data)
                for s, c, m in NonSeekingReader(io.BytesIO(data), validate_crcs=True)
                .iter_messages()]
    assert streamed == messages_read
    return {
        'header': (header.profile, header.library),
        'schemas': {k: (s.id, s.name, s.encoding, s.data) for k, s in summary.schemas.items()},
        'channels': {k: (c.id, c.topic, c.message_encoding, c.schema_id, c.metadata)
                     for k, c in summary.channels.items()},
        'statistics': (stats.message_count, stats.schema_count, stats.channel_count,
                       stats.attachment_count, stats.metadata_count, stats.message_start_time,
                       stats.message_end_time, dict(stats.channel_message_counts)),
        'messages': messages_read,
        'in_time_order': in_time_order,
        'metadata': [(m.name, m.metadata) for m in reader.iter_metadata()],
        'attachments': list(reader.iter_attachments()),
    }


def _check_crcs(data):
    """Check the CRCs mcap's readers leave alone: DataEnd's and the footer's summary CRC."""
    footer = len(data) - 8 - 29
    assert data[footer] == 0x02
    summary_start, offsets_start, crc = struct.unpack_from('<QQI', data, footer + 9)
    assert zlib.crc32(data[summary_start:footer + 25]) == crc != 0
    data_end = summary_start - 13
    assert data[data_end] == 0x0F
    assert struct.unpack_from('<I', data, data_end + 9)[0] == zlib.crc32(data[:data_end]) != 0
    assert summary_start < offsets_start < footer


@pytest.mark.parametrize('compression', ['none', 'lz4', 'zstd'])
def test_recorded_file_reads_as_mcaps_writer_file_of_the_same_records(session, tmp_path,
                                                                      compression):
    topics, records = session
    path = tmp_path / 'session.mcap'
    ours = _recorded(path, topics, records, compression)
    rosbag2 = list(make_reader(io.BytesIO(ours)).iter_metadata())[-1]
    assert rosbag2.name == 'rosbag2'
    reference = _reference(path, rosbag2.metadata, topics, records, compression)
    got, expected = _read(ours), _read(reference)
    for part in expected:
        assert got[part] == expected[part], part
    _check_crcs(reference)              # the check itself, held to the library's file
    _check_crcs(ours)
    assert len(got['messages']) == len(records) and got['attachments'] == []
    assert {t for t, *_ in got['messages']} == {'/joint_states', '/tf', '/diagnostics',
                                                '/jacket_cloth_node/markers',
                                                '/parameter_events'}
    summary = make_reader(io.BytesIO(ours)).get_summary()
    assert {c.compression for c in summary.chunk_indexes} == {
        '' if compression == 'none' else compression}
    assert len(summary.chunk_indexes) > 3      # flushed by stamps: several chunks
    bag = yaml.safe_load(rosbag2.metadata['serialized_metadata'])['rosbag2_bagfile_information']
    assert bag['message_count'] == len(records)
    per_topic = {t['topic_metadata']['name']: t['message_count']
                 for t in bag['topics_with_message_count']}
    assert per_topic == {topic: sum(1 for t, *_ in records if t == topic)
                         for topic, _, _ in topics.values()}
