# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A chunked MCAP writer whose per-message path is one struct pack and one buffer append.

Why not ``mcap.writer.Writer``: it builds a ``Message`` record object and writes it field by
field through a BytesIO, which made the recording a large share of each replayed input
(docs/performance.md). The rare records
(header, schemas, channels, chunk and summary records) still come from ``mcap.records``, so
the file layout is the library's; only messages and their chunk are packed here.
"""

import struct
import tempfile
import zlib
from collections.abc import Callable
from typing import BinaryIO

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel, ChunkIndex, DataEnd, Footer, Header, Metadata, MetadataIndex,
    Schema, Statistics, SummaryOffset)

try:
    import lz4.frame
except ImportError:             # the mcap package's own fallbacks: the codec is optional
    lz4 = None
try:
    import zstandard
except ImportError:
    zstandard = None

MAGIC = b'\x89MCAP0\r\n'
_MESSAGE = struct.Struct('<BQHIQQ')         # opcode, length, channel, sequence, log, publish
_CHUNK_HEAD = struct.Struct('<BQQQQI')      # opcode, length, start, end, size, crc
_FOOTER_HEAD = struct.Struct('<BQQQ')
_FIRST_CHUNK_BUFFER = 1 << 20               # grows (doubling) to the largest chunk seen


def _compressor(name):
    if name == 'lz4':
        if lz4 is None:
            raise ValueError('lz4 compression needs the lz4 package')
        return lz4.frame.compress
    if name == 'zstd':
        if zstandard is None:
            raise ValueError('zstd compression needs the zstandard package')
        # Level 1, not the library's 3: much faster for files hardly larger.
        return zstandard.ZstdCompressor(level=1).compress
    if name == '':
        return None
    raise ValueError(f'unknown MCAP compression {name!r} (lz4, zstd or "")')


def _message_index(channel_id, records):
    """Pack a MessageIndex record: (log time, offset in the chunk) of each message."""
    flat = [value for record in records for value in record]
    return (struct.pack('<BQHI', Opcode.MESSAGE_INDEX, 6 + 8 * len(flat), channel_id,
                        8 * len(flat))
            + struct.pack(f'<{len(flat)}Q', *flat))


class McapWriter:
    """An MCAP stream writer: chunks of messages, then the summary and the footer.

    Messages go into a chunk until ``flush()`` (or ``chunk_bytes``); ``finish()`` writes the
    summary (schemas, channels, statistics, chunk and metadata indexes) and the footer.

    Messages are packed in the caller's thread. Everything that touches the stream (a closed
    chunk's compression, CRC and write; the other records) goes through ``run``.

    :param stream: the binary stream the file is written to.
    :param compression: the chunks' codec: 'lz4', 'zstd' or '' (none).
    :param chunk_bytes: the size at which a chunk is closed, bytes.
    :param run: ``run(work, *args)`` does each piece of stream work; None: at once. A recorder
        can pass one that hands it to a writer thread in order, so the caller never waits for
        a chunk's compression.
    """

    def __init__(self, stream: BinaryIO, compression: str = 'lz4',
                 chunk_bytes: int = 8 * 1024 * 1024, run: Callable[..., None] | None = None):
        self._stream = stream
        self._compression = compression
        self._compress = _compressor(compression)
        self._chunk_bytes = chunk_bytes
        self._run = run or (lambda work, *args: work(*args))
        self._records = RecordBuilder()         # only in ``run``'s work
        self._schemas = []
        self._channels = []
        # The summary's chunk index, one record a chunk, waits in an unnamed temporary file
        # until finish(): held in memory, it grew a long session's node without bound.
        self._chunk_index_file = tempfile.TemporaryFile()
        self._chunk_count = 0
        self._metadata_indexes = []
        self.counts = {}                        # channel id -> its messages so far
        self._start = self._end = None          # log times of the closed chunks' messages
        # Chunk buffers are kept and reused: a fresh bytearray grown message by message cost
        # the live node 4.6 page faults per input (its pages, mapped anew each second). A
        # buffer goes back to ``_spare`` once its chunk is written (list append, pop: atomic).
        self._spare = []
        self._chunk = None
        self._new_chunk()

    def _new_chunk(self):
        self._chunk = self._spare.pop() if self._spare else bytearray(_FIRST_CHUNK_BUFFER)
        self._used = 0                      # bytes of ``_chunk`` holding this chunk's records
        self._index = {}                    # channel id -> [(log time, offset in chunk), ...]
        self._chunk_start = self._chunk_end = None

    def _write_records(self, *records):
        for record in records:
            record.write(self._records)
        self._stream.write(self._records.end())

    def start(self, profile: str = '', library: str = 'jacket_cloth_ros') -> None:
        """Write the magic and the header record.

        :param profile: the MCAP profile ('ros2' for ROS 2 messages).
        :param library: the writer's name, as the header says it.
        """
        self._run(self._stream.write, MAGIC)
        self._run(self._write_records, Header(profile=profile, library=library))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Write a schema record; return its id.

        :param name: the message type (``pkg/msg/Type``).
        :param encoding: the schema's encoding ('ros2msg').
        :param data: the schema's definition text, encoded.
        """
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._run(self._write_records, schema)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int,
                         metadata: dict[str, str] | None = None) -> int:
        """Write a channel record; return its id.

        :param topic: the channel's topic.
        :param message_encoding: its messages' encoding ('cdr').
        :param schema_id: the id ``register_schema`` gave its type.
        :param metadata: the channel's metadata (the QoS profiles); None: none.
        """
        channel = Channel(id=len(self._channels) + 1, topic=topic, schema_id=schema_id,
                          message_encoding=message_encoding, metadata=dict(metadata or {}))
        self._channels.append(channel)
        self.counts[channel.id] = 0
        self._run(self._write_records, channel)
        return channel.id

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        """Pack a message into the open chunk, closing the chunk once it reaches its size.

        :param channel_id: the id ``register_channel`` gave its topic.
        :param log_time: when it was recorded, ns.
        :param data: the serialized message.
        :param publish_time: when it was published, ns.
        :param sequence: its sequence number on the channel.
        """
        offset = self._used
        end = offset + _MESSAGE.size + len(data)
        if end > len(self._chunk):
            self._chunk += bytes(max(end, 2 * len(self._chunk)) - len(self._chunk))
        _MESSAGE.pack_into(self._chunk, offset, Opcode.MESSAGE, 22 + len(data), channel_id,
                           sequence, log_time, publish_time)
        self._chunk[offset + _MESSAGE.size:end] = data
        self._used = end
        index = self._index.get(channel_id)
        if index is None:
            index = self._index[channel_id] = []
        index.append((log_time, offset))
        self.counts[channel_id] += 1
        if self._chunk_start is None:
            self._chunk_start = self._chunk_end = log_time
        elif log_time < self._chunk_start:
            self._chunk_start = log_time
        elif log_time > self._chunk_end:
            self._chunk_end = log_time
        if end > self._chunk_bytes:
            self._close_chunk()

    def time_range(self) -> tuple[int, int] | None:
        """(first, last) log time of the messages so far, or None before the first."""
        spans = [s for s in ((self._start, self._end), (self._chunk_start, self._chunk_end))
                 if s[0] is not None]
        if not spans:
            return None
        return min(s[0] for s in spans), max(s[1] for s in spans)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write a metadata record (indexed in the summary).

        :param name: the record's name.
        :param data: its key-value pairs.
        """
        self._run(self._write_metadata, Metadata(name=name, metadata=dict(data)))

    def _write_metadata(self, metadata):
        offset = self._stream.tell()
        metadata.write(self._records)
        self._metadata_indexes.append(
            MetadataIndex(offset=offset, length=self._records.count, name=metadata.name))
        self._stream.write(self._records.end())

    def flush(self) -> None:
        """Close the chunk in progress (if any) into the file and flush the stream."""
        self._close_chunk()
        self._run(self._stream.flush)

    def _close_chunk(self):
        if self._chunk_start is None:
            return
        start, end = self._chunk_start, self._chunk_end
        self._start, self._end = self.time_range()
        self._run(self._write_chunk, self._chunk, self._used, self._index, start, end)
        self._new_chunk()

    def _write_chunk(self, buffer, used, message_indexes, start, end):
        with memoryview(buffer) as view, view[:used] as raw:
            self._write_chunk_records(raw, message_indexes, start, end)
        self._spare.append(buffer)

    def _write_chunk_records(self, raw, message_indexes, start, end):
        packed = self._compress(raw) if self._compress else raw
        compression = self._compression.encode()
        at = self._stream.tell()
        length = 8 + 8 + 8 + 4 + 4 + len(compression) + 8 + len(packed)
        self._stream.write(_CHUNK_HEAD.pack(Opcode.CHUNK, length, start, end, len(raw),
                                            zlib.crc32(raw)))
        self._stream.write(struct.pack('<I', len(compression)) + compression)
        self._stream.write(struct.pack('<Q', len(packed)))
        self._stream.write(packed)
        indexes_at = self._stream.tell()
        offsets = {}
        indexes = bytearray()
        for channel_id, records in message_indexes.items():
            offsets[channel_id] = indexes_at + len(indexes)
            indexes += _message_index(channel_id, records)
        self._stream.write(indexes)
        ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=at,
            chunk_length=9 + length, message_index_offsets=offsets,
            message_index_length=len(indexes), compression=self._compression,
            compressed_size=len(packed), uncompressed_size=len(raw)).write(self._records)
        self._chunk_index_file.write(self._records.end())
        self._chunk_count += 1

    def finish(self) -> None:
        """Write the last chunk, the summary and the footer (through ``run``, after all else).

        The stream stays open.
        """
        self._close_chunk()
        first, last = self.time_range() or (0, 0)
        statistics = Statistics(
            message_count=sum(self.counts.values()), schema_count=len(self._schemas),
            channel_count=len(self._channels), attachment_count=0,
            metadata_count=0, chunk_count=0, message_start_time=first,
            message_end_time=last, channel_message_counts=dict(self.counts))
        self._run(self._write_summary, statistics)

    def _write_summary(self, statistics):
        # The chunk and metadata counts are the writer side's: complete only here.
        statistics.chunk_count = self._chunk_count
        statistics.metadata_count = len(self._metadata_indexes)
        self._write_records(DataEnd(data_section_crc=0))
        summary_start = self._stream.tell()
        offsets = []
        crc = 0

        def put(data):
            nonlocal crc
            crc = zlib.crc32(data, crc)
            self._stream.write(data)

        def group(opcode, records=(), spilled=None):
            begin = self._stream.tell()
            for record in records:
                record.write(self._records)
            put(self._records.end())
            if spilled is not None:
                spilled.seek(0)
                while block := spilled.read(1 << 20):
                    put(block)
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=begin,
                                         group_length=self._stream.tell() - begin))

        group(Opcode.SCHEMA, self._schemas)
        group(Opcode.CHANNEL, self._channels)
        group(Opcode.STATISTICS, [statistics])
        group(Opcode.CHUNK_INDEX, spilled=self._chunk_index_file)
        group(Opcode.METADATA_INDEX, self._metadata_indexes)
        self._chunk_index_file.close()
        offsets_start = self._stream.tell()
        for offset in offsets:
            offset.write(self._records)
        put(self._records.end())
        crc = zlib.crc32(_FOOTER_HEAD.pack(Opcode.FOOTER, 20, summary_start, offsets_start), crc)
        self._write_records(Footer(summary_start=summary_start,
                                   summary_offset_start=offsets_start, summary_crc=crc))
        self._stream.write(MAGIC)
