# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Our MCAP writer against the mcap package's readers, which check every CRC they meet."""

import errno
import io
import random
import struct
import zlib

import pytest
from conftest import FillingFile
from mcap.reader import NonSeekingReader, SeekingReader
from mcap.records import Chunk, ChunkIndex, DataEnd, MessageIndex
from mcap.stream_reader import StreamReader, get_chunk_data_stream

from jacket_cloth_ros.recording.mcap_file import McapWriter


def _written(compression):
    """Three channels over four chunks, messages of varied sizes, one stamp out of order."""
    out = io.BytesIO()
    w = McapWriter(out, compression=compression, chunk_bytes=2000)
    w.start(profile='ros2', library='test')
    schema = w.register_schema('std_msgs/msg/String', 'ros2msg', b'string data')
    channels = [w.register_channel(f'/t{k}', 'cdr', schema, {'k': str(k)}) for k in range(3)]
    sent = []
    for i in range(40):
        channel = channels[i % 3]
        stamp = 990 if i == 35 else 1000 + 10 * i
        data = bytes([i]) * (7 + 37 * (i % 5))
        w.add_message(channel, stamp, data, stamp + 1, sequence=i)
        sent.append((channel, i, stamp, stamp + 1, data))
        if i == 30:
            w.flush()
    w.add_metadata('session', {'a': 'b'})
    w.finish()
    return out.getvalue(), sent


@pytest.mark.parametrize('compression', ['lz4', 'zstd', ''])
def test_mcap_readers_get_every_message_back_with_crcs_checked(compression):
    data, sent = _written(compression)
    for reader in (SeekingReader(io.BytesIO(data), validate_crcs=True),
                   NonSeekingReader(io.BytesIO(data), validate_crcs=True)):
        got = [(c.id, m.sequence, m.log_time, m.publish_time, m.data)
               for _, c, m in reader.iter_messages(log_time_order=False)]
        assert sorted(got) == sorted(sent)
    summary = SeekingReader(io.BytesIO(data), validate_crcs=True).get_summary()
    stats = summary.statistics
    assert stats.message_count == 40 and stats.chunk_count == len(summary.chunk_indexes) > 2
    assert (stats.message_start_time, stats.message_end_time) == (990, 1390)
    assert dict(stats.channel_message_counts) == {1: 14, 2: 13, 3: 13}
    assert [c.topic for c in summary.channels.values()] == ['/t0', '/t1', '/t2']
    assert summary.channels[2].metadata == {'k': '1'}
    assert [m.name for m in SeekingReader(io.BytesIO(data)).iter_metadata()] == ['session']
    assert data.endswith(b'\x89MCAP0\r\n')
    # The footer's summary CRC covers the summary and the footer up to itself (MCAP spec).
    footer = len(data) - 8 - 29
    summary_start, _, crc = struct.unpack_from('<QQI', data, footer + 9)
    assert zlib.crc32(data[summary_start:footer + 25]) == crc != 0
    # DataEnd's CRC covers the data section, from the magic to DataEnd (issue 48 item 4: it
    # was 0, so no reader could tell a changed set-up record).
    data_end = summary_start - 13
    assert data[data_end] == 0x0F
    assert struct.unpack_from('<I', data, data_end + 9)[0] == zlib.crc32(data[:data_end]) != 0


def test_chunk_and_message_indexes_point_at_their_records():
    # Readers that seek by time (Foxglove, rosbag2) trust these offsets without reading chunks.
    data, _ = _written('lz4')
    summary = SeekingReader(io.BytesIO(data)).get_summary()
    for index in summary.chunk_indexes:
        assert isinstance(index, ChunkIndex)
        chunk = next(StreamReader(io.BytesIO(data[index.chunk_start_offset:]),
                                  skip_magic=True, emit_chunks=True).records)
        assert isinstance(chunk, Chunk)
        assert 9 + struct.unpack_from('<Q', data, index.chunk_start_offset + 1)[0] == \
            index.chunk_length
        records = get_chunk_data_stream(chunk, validate_crc=True)[0].read(chunk.uncompressed_size)
        stamps = []
        for channel, offset in index.message_index_offsets.items():
            found = next(StreamReader(io.BytesIO(data[offset:]), skip_magic=True).records)
            assert isinstance(found, MessageIndex) and found.channel_id == channel
            for log_time, at in found.records:
                opcode, _, channel_id, _, stamp = struct.unpack_from('<BQHIQ', records, at)
                assert (opcode, channel_id, stamp) == (5, channel, log_time)
                stamps.append(stamp)
        assert (index.message_start_time, index.message_end_time) == (min(stamps), max(stamps))


def test_an_unknown_compression_is_refused():
    with pytest.raises(ValueError, match='brotli'):
        McapWriter(io.BytesIO(), compression='brotli')


def test_chunk_buffers_grow_and_are_reused_without_mixing_chunks():
    # Buffers are reused once written; a deferred ``run`` (as the recorder's writer thread)
    # writes chunks after later ones are filled, and a message can outgrow the buffer.
    out, deferred = io.BytesIO(), []
    w = McapWriter(out, compression='lz4', chunk_bytes=3 << 20,
                   run=lambda work, *args: deferred.append((work, args)))
    w.start()
    channel = w.register_channel('/big', 'cdr', 0)
    sizes = [10, 3 << 20, 5, 200_000, 7, 1 << 20, 3]
    for i, size in enumerate(sizes):
        w.add_message(channel, 100 + i, bytes([i + 1]) * size, 100 + i, sequence=i)
        if i % 2:
            w.flush()
            if i == 3:                     # the first chunks' buffers come back for reuse
                for work, args in deferred:
                    work(*args)
                deferred.clear()
    w.finish()
    for work, args in deferred:
        work(*args)
    got = [(m.sequence, m.data) for _, _, m in SeekingReader(
        io.BytesIO(out.getvalue()), validate_crcs=True).iter_messages()]
    assert got == [(i, bytes([i + 1]) * size) for i, size in enumerate(sizes)]


def test_a_message_is_recorded_as_it_was_when_given_though_its_buffer_changes_after():
    # A message's bytes wait in the chunk's list until the writing side lays the chunk out;
    # a caller's buffer (a bytearray, a view) is copied when given, a ``bytes`` is held.
    out, deferred = io.BytesIO(), []
    w = McapWriter(out, compression='', run=lambda work, *args: deferred.append((work, args)))
    w.start()
    channel = w.register_channel('/reused', 'cdr', 0)
    buffer = bytearray(b'first')
    w.add_message(channel, 1, buffer, 1, sequence=0)
    buffer[:] = b'other'
    w.add_message(channel, 2, memoryview(buffer), 2, sequence=1)
    buffer[:] = b'third'
    w.add_message(channel, 3, bytes(buffer), 3, sequence=2)
    buffer[:] = b'fifth'
    w.finish()
    for work, args in deferred:
        work(*args)
    got = [m.data for _, _, m in SeekingReader(io.BytesIO(out.getvalue()),
                                               validate_crcs=True).iter_messages()]
    assert got == [b'first', b'other', b'third']


def test_the_reader_refuses_damage_and_keeps_the_readable_part_of_a_cut(tmp_path):
    from jacket_cloth_ros.recording.reader import RecordingError, read_recording
    data, sent = _written('')
    path = tmp_path / 'x.mcap'
    path.write_bytes(data)
    assert len(read_recording(str(path)).messages) == len(sent)
    summary = SeekingReader(io.BytesIO(data)).get_summary()
    first = summary.chunk_indexes[0]
    footer = len(data) - 8 - 29
    summary_start = struct.unpack_from('<Q', data, footer + 9)[0]
    for at in (first.chunk_start_offset + first.chunk_length - 20,     # a message's bytes
               summary_start + 30):                                    # the summary's
        bad = bytearray(data)
        bad[at] ^= 0x01
        path.write_bytes(bytes(bad))
        with pytest.raises(RecordingError, match='damaged file'):
            read_recording(str(path))
    # Cut inside the last chunk: no summary, the chunks before it are read, no error.
    last = summary.chunk_indexes[-1]
    path.write_bytes(data[:last.chunk_start_offset + last.chunk_length // 2])
    cut = read_recording(str(path))
    assert not cut.complete and 0 < len(cut.messages) < len(sent)


class _SmallDisk(io.BytesIO):
    """A file on a disk of ``room`` bytes, written as a raw file is: what fits, then ENOSPC."""

    def __init__(self, room):
        super().__init__()
        self.room = room

    def write(self, data):
        free = self.room - max(self.tell(), len(self.getvalue()))
        if free <= 0 and len(data):
            raise OSError(errno.ENOSPC, 'No space left on device')
        return super().write(bytes(data)[:free])


def _filled(room, flush_every=100, count=1000):
    """Messages of incompressible bytes until the disk of ``room`` bytes is full, then finish.

    Returns (writer, the file's bytes, messages sent, messages in chunks written before the
    write that found no room).
    """
    rng = random.Random(38)
    disk = _SmallDisk(room)
    w = McapWriter(disk, compression='zstd')
    w.start(profile='ros2', library='test')
    channel = w.register_channel('/t', 'cdr', w.register_schema('s/msg/S', 'ros2msg', b'x'))
    sent, before = [], None
    for i in range(count):
        data = rng.randbytes(1000)
        w.add_message(channel, 1000 + i, data, 1000 + i, sequence=i)
        sent.append(data)
        if (i + 1) % flush_every == 0:
            try:
                w.flush()
            except OSError as e:
                assert e.errno == errno.ENOSPC
                before = i + 1 - flush_every
                break
    w.finish()
    return w, disk.getvalue(), sent, before


def test_a_full_disk_keeps_what_fits_of_the_chunk_it_filled_in_and_ends_the_file(tmp_path):
    # The chunk being written when the disk filled was lost whole, and the file had no end:
    # now it is cut back, written in pieces as far as the room goes, and the summary follows.
    from jacket_cloth_ros.recording.reader import read_recording
    w, data, sent, before = _filled(room=360_000)
    assert before is not None and before < len(sent)
    got = [(m.sequence, m.data) for _, _, m in SeekingReader(
        io.BytesIO(data), validate_crcs=True).iter_messages()]
    assert len(got) + w.unwritten == len(sent) and len(got) > before + 20, (len(got), before)
    assert got == [(i, sent[i]) for i in range(len(got))]
    summary = SeekingReader(io.BytesIO(data)).get_summary()
    assert summary.statistics.message_count == len(got)
    # The data section's CRC is of the bytes the file kept, not of the ones cut back.
    records = list(StreamReader(io.BytesIO(data), validate_crcs=True).records)
    assert [r.data_section_crc for r in records if isinstance(r, DataEnd)] != [0]
    path = tmp_path / 'full.mcap'
    path.write_bytes(data)
    recording = read_recording(str(path))
    assert recording.complete and len(recording.messages) == len(got)


def _two_chunks(disk):
    """A writer on ``disk`` whose first chunk of 100 incompressible messages is written."""
    rng = random.Random(38)
    w = McapWriter(disk, compression='zstd')
    w.start(profile='ros2', library='test')
    channel = w.register_channel('/t', 'cdr', w.register_schema('s/msg/S', 'ros2msg', b'x'))
    for i in range(200):
        w.add_message(channel, 1000 + i, rng.randbytes(1000), 1000 + i)
        if i == 99:
            w.flush()
    return w


def test_a_disk_without_room_for_the_end_leaves_a_file_cut_at_a_whole_record(tmp_path):
    # Not even the summary fits: the file stops at its last whole chunk, read as a cut one.
    from jacket_cloth_ros.recording.reader import read_recording
    room = len(_two_chunks(_SmallDisk(10 ** 9))._stream.getvalue()) + 10
    disk = _SmallDisk(room)
    w = _two_chunks(disk)
    with pytest.raises(OSError) as raised:
        w.finish()
    assert raised.value.errno == errno.ENOSPC and w.unwritten == 100
    path = tmp_path / 'cut.mcap'
    path.write_bytes(disk.getvalue())
    assert len(disk.getvalue()) == room - 10
    recording = read_recording(str(path))
    assert not recording.complete and len(recording.messages) == 100


_FILLED_BY_THE_KERNEL = '''
import random, resource, signal, sys
from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)     # the write fails with EFBIG instead
resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[2]), int(sys.argv[2])))
rec = SessionRecorder(sys.argv[1], flush_period_ns=100, compression='lz4')
rec.add_topic('/t', 'std_msgs/msg/String', qos_profile_yaml())
rng = random.Random(38)
for i in range(1000):
    try:
        rec.write('/t', rng.randbytes(1000), 1000 + i)
    except OSError as e:
        print('stopped at', i + 1, e.errno)
        break
rec.close()
print('unwritten', rec.unwritten)
'''


def test_a_recording_whose_file_reaches_the_kernels_limit_is_finished(tmp_path):
    # A real file and the kernel's own refusal (a file size limit: EFBIG, as a full disk's
    # ENOSPC), through the recorder's unbuffered file.
    import subprocess
    import sys
    from mcap.reader import make_reader
    from jacket_cloth_ros.recording.reader import read_recording
    path = tmp_path / 'limited.mcap'
    done = subprocess.run([sys.executable, '-c', _FILLED_BY_THE_KERNEL, str(path), '300000'],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.split('\n')
    stopped, unwritten = int(lines[0].split()[2]), int(lines[1].split()[1])
    assert lines[0].split()[3] == str(errno.EFBIG) and unwritten > 0
    recording = read_recording(str(path))
    assert recording.complete and len(recording.messages) == stopped - unwritten
    assert len(recording.messages) > 250            # the chunks before, and pieces of the last
    with open(path, 'rb') as f:
        reader = make_reader(f, validate_crcs=True)
        assert sum(1 for _ in reader.iter_messages()) == len(recording.messages)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    assert f'message_count: {len(recording.messages)}' in meta['rosbag2']['serialized_metadata']


def test_the_recorder_never_writes_over_a_file_made_after_any_check(tmp_path):
    # A check that the path is free, then open(path, 'wb'): a file made in between was lost.
    from jacket_cloth_ros.recording.writer import SessionRecorder
    for name in ('x.mcap', 'bag'):
        path = tmp_path / name
        path.write_bytes(b'made since the check') if name.endswith('.mcap') else path.mkdir()
        with pytest.raises(FileExistsError):
            SessionRecorder(str(path))
    assert (tmp_path / 'x.mcap').read_bytes() == b'made since the check'
    assert list((tmp_path / 'bag').iterdir()) == []


def test_chunk_indexes_the_temporary_folder_has_no_room_for_wait_in_memory():
    # The summary's chunk index waits in a temporary file, often on the recording's disk.
    out = io.BytesIO()
    w = McapWriter(out, compression='lz4')
    w._chunk_index_file = _SmallDisk(150)           # room for one record and a part
    w.start(profile='ros2', library='test')
    channel = w.register_channel('/t', 'cdr', w.register_schema('s/msg/S', 'ros2msg', b'x'))
    for i in range(50):
        w.add_message(channel, 1000 + i, bytes([i]) * 100, 1000 + i, sequence=i)
        if i % 10 == 9:
            w.flush()
    w.finish()
    reader = SeekingReader(io.BytesIO(out.getvalue()), validate_crcs=True)
    assert len(reader.get_summary().chunk_indexes) == 5
    assert [m.sequence for _, _, m in reader.iter_messages()] == list(range(50))


def test_a_bag_closed_on_a_full_disk_has_no_metadata_yaml_rather_than_a_cut_one(
        tmp_path, monkeypatch):
    # Review: the salvage filled the disk up to the summary, then metadata.yaml found no room
    # and was left empty, and the reader refused the whole folder although its .mcap was
    # finished. Without one, the folder is read from its .mcap file.
    import builtins
    from jacket_cloth_ros.recording import writer
    from jacket_cloth_ros.recording.reader import read_recording
    from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
    from jacket_cloth_ros.ros.cdr import joint_state
    bag = tmp_path / 'bag'
    rec = SessionRecorder(str(bag))
    rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    for k in range(50):
        rec.write('/joint_states', joint_state(k * 1_000_000, ['a'], [0.1 * k]), k * 1_000_000)

    def full(path, mode='r', *args, **kwargs):
        if str(path).endswith('metadata.yaml'):
            builtins.open(path, mode, *args, **kwargs).close()       # made, then no room
            raise OSError(errno.ENOSPC, 'No space left on device')
        return builtins.open(path, mode, *args, **kwargs)
    monkeypatch.setattr(writer, 'open', full, raising=False)
    rec.close()
    assert rec.metadata_lost and not (bag / 'metadata.yaml').exists()
    assert len(read_recording(str(bag)).messages) == 50


@pytest.mark.parametrize('background', [False, True])
def test_a_full_disk_ends_a_recording_finished_with_or_without_its_writer_thread(
        tmp_path, background):
    # The node writes on a writer thread: a full disk's error came back at the next chunk and
    # the close, which then left the file without its end. Now, as in the caller's thread, the
    # writer says it once and holds the chunks with no room, and the close writes what fits.
    from jacket_cloth_ros.recording.writer import SessionRecorder
    path = tmp_path / 'session.mcap'
    rec = SessionRecorder(str(path), background=background, compression='lz4')
    rec.add_topic('/t', 'std_msgs/msg/String')
    rec._writer._stream = FillingFile(rec._writer._stream, rec._writer._stream.tell() + 300_000)
    rng = random.Random(38)
    sent, heard = [], []
    for i in range(1000):                       # a chunk each 100 (a second of stamps)
        sent.append(rng.randbytes(1000))        # in the chunk even if its close finds no room
        try:
            rec.write('/t', sent[-1], 10 ** 7 * i)
        except OSError as e:
            heard.append(e.errno)
            break
    rec.close()
    # In the caller's thread the write that found no room says so; the writer thread's error
    # is heard at a later chunk or (on a quick run) not before the close, which counts it.
    assert heard == [errno.ENOSPC] or background and heard in ([], [errno.ENOSPC])
    with open(path, 'rb') as f:
        got = [m.data for _, _, m in SeekingReader(f, validate_crcs=True).iter_messages()]
    assert got == sent[:len(got)] and len(got) + rec.unwritten == len(sent)
    assert 200 < len(got) < len(sent)           # what fit, in pieces of the chunk it filled


@pytest.mark.parametrize('at', range(3))
def test_a_stop_inside_add_topic_leaves_a_recording_that_closes_whole(tmp_path, monkeypatch, at):
    # A SIGTERM that landed while a replay added its topics (between a channel and its QoS)
    # made the close raise KeyError with a traceback, exit 1, its output left behind (seen in
    # `make test`). A stop anywhere in add_topic now leaves the topic whole or absent.
    from jacket_cloth_ros.recording import writer
    from jacket_cloth_ros.recording.reader import read_recording
    recorder = writer.SessionRecorder(str(tmp_path / 's.mcap'))
    recorder.add_topic('/joint_states', 'sensor_msgs/msg/JointState')
    steps = iter(range(10))

    def stopping(real):
        def call(*args, **kwargs):
            if next(steps) == at:
                raise KeyboardInterrupt
            return real(*args, **kwargs)
        return call
    monkeypatch.setattr(writer.yaml, 'safe_load', stopping(writer.yaml.safe_load))
    monkeypatch.setattr(recorder._writer, 'register_channel',
                        stopping(recorder._writer.register_channel))
    with pytest.raises(KeyboardInterrupt):
        recorder.add_topic('/jacket_cloth_node/wind', 'geometry_msgs/msg/Vector3Stamped')
        recorder.add_topic('/tf', 'tf2_msgs/msg/TFMessage')
    monkeypatch.undo()
    recorder.close()
    topics = read_recording(str(tmp_path / 's.mcap')).topics
    assert '/joint_states' in topics and len(topics) <= 2, topics
