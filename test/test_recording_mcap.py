# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Our MCAP writer against the mcap package's readers, which check every CRC they meet."""

import io
import struct
import zlib

import pytest
from mcap.reader import NonSeekingReader, SeekingReader
from mcap.records import Chunk, ChunkIndex, MessageIndex
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
