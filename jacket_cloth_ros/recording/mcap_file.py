# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A chunked MCAP writer whose per-message path is one struct pack and a list append.

Why not ``mcap.writer.Writer``: it builds a ``Message`` record object and writes it field by
field through a BytesIO, which made the recording a large share of each replayed input
(docs/performance.md). The rare records
(header, schemas, channels, chunk and summary records) still come from ``mcap.records``, so
the file layout is the library's; only messages and their chunk are packed here.
"""

import struct
import tempfile
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import BinaryIO

from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel, ChunkIndex, DataEnd, Footer, Header, Metadata, MetadataIndex,
    Schema, Statistics, SummaryOffset)

from .disk import no_room

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
# The pieces a chunk the disk had no room for is written in at the end: small, so that most of
# what fits is kept, and each one dropped whole when the summary needs its room.
PIECE_BYTES = 16 * 1024


@dataclass
class _Held:
    """A chunk's records the file had no room for: written in pieces by finish()."""

    raw: bytes
    indexes: dict                   # channel id -> [(log time, offset in raw), ...]
    start: int
    end: int


@dataclass
class _Written:
    """A chunk in the file: where it starts, its ChunkIndex record, what it holds."""

    at: int
    index_record: bytes
    counts: dict = field(default_factory=dict)     # channel id -> its messages in the chunk
    start: int = 0
    end: int = 0
    crc: int = 0                    # the data section's CRC before it: a cut back to ``at``


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

    A message's head is packed in the caller's thread and its bytes held as they are (copied
    only if not ``bytes``). Everything else (laying a closed chunk out, its compression, CRC
    and write; the other records) goes through ``run``.

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
        # The data section's CRC (DataEnd's), of every byte written so far: a flipped bit in
        # the set-up records (sim_rate 120 -> 130) then fails the file's check, as a chunk's
        # does. Kept as the bytes go out, and put back with them when a write is cut back.
        self._crc = 0
        self._schemas = []
        self._channels = []
        # The summary's chunk index, one record a chunk, waits in an unnamed temporary file
        # until finish(): held in memory, it grew a long session's node without bound.
        # Unbuffered, so that a record the temporary folder's disk has no room for is cut back
        # whole: it and the ones after it wait in ``_index_tail`` instead.
        self._chunk_index_file = tempfile.TemporaryFile(buffering=0)
        self._index_tail = []
        self._chunk_count = 0
        self._metadata_indexes = []
        self.counts = {}                        # channel id -> its messages so far
        # What the file holds (the writing side's): what the summary states.
        self._in_file = {}                      # channel id -> its messages written
        self._file_range = None                 # (first, last) log time written
        self._held = []                         # chunks the file had no room for, in order
        self.unwritten = 0                      # messages finish() found no room for
        # Chunk buffers are kept and reused: a fresh bytearray grown message by message cost
        # the live node 4.6 page faults per input (its pages, mapped anew each second). Only
        # the writing side takes and returns them.
        self._spare = []
        self._new_chunk()

    def _new_chunk(self):
        # The chunk's records as the caller gave them (each message's head, then its bytes),
        # laid into a buffer only where the chunk is written: copying a markers message into
        # the chunk in the caller's thread was most of its recording's cost.
        self._parts = []
        self._used = 0                      # bytes of this chunk's records
        self._index = {}                    # channel id -> [(log time, offset in chunk), ...]
        self._chunk_start = self._chunk_end = None

    def _write_records(self, *records):
        for record in records:
            record.write(self._records)
        with self._whole():
            self._put(self._records.end())

    def _put(self, data):
        """Write all of ``data`` to the file, counted in the data section's CRC."""
        _write_all(self._stream, data)
        self._crc = zlib.crc32(data, self._crc)

    def _whole(self):
        """Roll the file (and the CRC) back to where it is now if the block finds no room."""
        return _RollBack(self._stream, self)

    def _cut(self, at, crc):
        """Cut the file back to ``at``, where the data section's CRC was ``crc``."""
        _rollback(self._stream, at)
        self._crc = crc

    def start(self, profile: str = '', library: str = 'jacket_cloth_ros') -> None:
        """Write the magic and the header record.

        :param profile: the MCAP profile ('ros2' for ROS 2 messages).
        :param library: the writer's name, as the header says it.
        """
        self._run(self._put, MAGIC)
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
        if type(data) is not bytes:     # held until the chunk is written: the caller's may change
            data = bytes(data)
        offset = self._used
        end = offset + _MESSAGE.size + len(data)
        self._parts += (_MESSAGE.pack(Opcode.MESSAGE, 22 + len(data), channel_id, sequence,
                                      log_time, publish_time), data)
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

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write a metadata record (indexed in the summary).

        :param name: the record's name.
        :param data: its key-value pairs.
        """
        self._run(self._write_metadata, Metadata(name=name, metadata=dict(data)))

    def _write_metadata(self, metadata):
        offset = self._stream.tell()
        metadata.write(self._records)
        length = self._records.count
        with self._whole():
            self._put(self._records.end())
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=length,
                                                    name=metadata.name))

    def flush(self) -> None:
        """Close the chunk in progress (if any) into the file and flush the stream."""
        self._close_chunk()
        self._run(self._stream.flush)

    def _close_chunk(self):
        if self._chunk_start is None:
            return
        start, end = self._chunk_start, self._chunk_end
        try:
            self._run(self._write_chunk, self._parts, self._used, self._index, start, end)
        except OSError as e:
            if no_room(e):
                self._new_chunk()       # that one is held: it is not written twice
            raise
        self._new_chunk()

    def _write_chunk(self, parts, used, message_indexes, start, end):
        buffer = self._spare.pop() if self._spare else bytearray(_FIRST_CHUNK_BUFFER)
        if used > len(buffer):
            buffer += bytes(max(used, 2 * len(buffer)) - len(buffer))
        at = 0
        for part in parts:
            buffer[at:at + len(part)] = part
            at += len(part)
        with memoryview(buffer) as view, view[:used] as raw:
            if self._held:              # after one that found no room: in order, at finish
                self._held.append(_Held(bytes(raw), message_indexes, start, end))
            else:
                try:
                    written = self._write_chunk_records(raw, message_indexes, start, end)
                except OSError as e:
                    if not no_room(e):
                        raise
                    self._held.append(_Held(bytes(raw), message_indexes, start, end))
                    raise
                self._commit(written)
        self._spare.append(buffer)

    def _commit(self, written):
        """Count a chunk written as the file's: its index entry, messages and times."""
        self._spill(written.index_record)
        self._chunk_count += 1
        for channel_id, n in written.counts.items():
            self._in_file[channel_id] = self._in_file.get(channel_id, 0) + n
        self._file_range = _span(self._file_range, (written.start, written.end))

    def _spill(self, record):
        """Keep a chunk's index record for the summary: in the temporary file while it has room."""
        if not self._index_tail:
            try:
                with _RollBack(self._chunk_index_file):
                    _write_all(self._chunk_index_file, record)
                return
            except OSError as e:
                if not no_room(e):
                    raise
        self._index_tail.append(record)

    def _write_chunk_records(self, raw, message_indexes, start, end):
        """Write a chunk and its message indexes, whole or (on no room) not at all."""
        packed = self._compress(raw) if self._compress else raw
        compression = self._compression.encode()
        at, crc = self._stream.tell(), self._crc
        length = 8 + 8 + 8 + 4 + 4 + len(compression) + 8 + len(packed)
        head = (_CHUNK_HEAD.pack(Opcode.CHUNK, length, start, end, len(raw), zlib.crc32(raw))
                + struct.pack('<I', len(compression)) + compression
                + struct.pack('<Q', len(packed)))
        indexes_at = at + len(head) + len(packed)
        offsets = {}
        indexes = bytearray()
        for channel_id, records in message_indexes.items():
            offsets[channel_id] = indexes_at + len(indexes)
            indexes += _message_index(channel_id, records)
        with self._whole():
            self._put(head)
            self._put(packed)
            self._put(indexes)
        ChunkIndex(
            message_start_time=start, message_end_time=end, chunk_start_offset=at,
            chunk_length=9 + length, message_index_offsets=offsets,
            message_index_length=len(indexes), compression=self._compression,
            compressed_size=len(packed), uncompressed_size=len(raw)).write(self._records)
        return _Written(at, self._records.end(),
                        {c: len(records) for c, records in message_indexes.items()}, start, end,
                        crc)

    def finish(self, closing: Callable[[dict, tuple], dict] | None = None) -> None:
        """Write the last chunk, the summary and the footer (through ``run``, after all else).

        If the disk filled, what it had no room for is written in pieces as far as the room
        goes, then the end; pieces are given up, last first, until the end fits. The file
        then ends as a finished one, and ``unwritten`` counts the messages not in it. With no
        room even for the end, the file is left at its last whole record (a cut file) and the
        error raised. The stream stays open.

        :param closing: ``closing(counts, (first, last))`` gives the metadata records written
            just before the summary ({name: {key: value}}), from the messages the file holds:
            channel id -> count, and their first and last log times.
        """
        try:
            self._close_chunk()
        except OSError as e:
            if not no_room(e):
                raise
        self._run(self._write_end, closing or (lambda counts, span: {}))

    def _write_end(self, closing):
        pieces = self._write_held()
        while True:
            at, crc, metadata = self._stream.tell(), self._crc, len(self._metadata_indexes)
            try:
                self._write_closing(pieces, closing)
                break
            except OSError as e:
                if not no_room(e):
                    raise
                del self._metadata_indexes[metadata:]
                self._cut(at, crc)
                if not pieces:
                    self.unwritten = self._unwritten(pieces)
                    raise
                piece = pieces.pop()
                self._cut(piece.at, piece.crc)              # its room for the summary's
        self.unwritten = self._unwritten(pieces)
        self._held = []
        self._chunk_index_file.close()

    def _write_held(self):
        """Write the held chunks in pieces until one finds no room; the pieces written."""
        pieces = []
        for held in self._held:
            for piece in _pieces(held, PIECE_BYTES):
                try:
                    pieces.append(self._write_chunk_records(*piece))
                except OSError as e:
                    if not no_room(e):
                        raise
                    return pieces
        return pieces

    def _unwritten(self, pieces):
        """Count the messages finish() found no room for."""
        written = sum(self._in_file.values()) + sum(sum(p.counts.values()) for p in pieces)
        return sum(self.counts.values()) - written

    def _write_closing(self, pieces, closing):
        """Write the closing metadata, the summary and the footer, counting ``pieces`` in."""
        counts = dict(self._in_file)
        span = self._file_range
        for piece in pieces:
            for channel_id, n in piece.counts.items():
                counts[channel_id] = counts.get(channel_id, 0) + n
            span = _span(span, (piece.start, piece.end))
        counts = {c.id: counts.get(c.id, 0) for c in self._channels}
        first, last = span or (0, 0)
        for name, data in closing(counts, (first, last)).items():
            self._write_metadata(Metadata(name=name, metadata=dict(data)))
        statistics = Statistics(
            message_count=sum(counts.values()), schema_count=len(self._schemas),
            channel_count=len(self._channels), attachment_count=0,
            metadata_count=len(self._metadata_indexes),
            chunk_count=self._chunk_count + len(pieces), message_start_time=first,
            message_end_time=last,
            # Channels with messages only, as mcap's own writers (Python, C++) count them.
            channel_message_counts={c: n for c, n in counts.items() if n})
        with self._whole():
            self._write_summary(statistics, b''.join(
                self._index_tail + [p.index_record for p in pieces]))

    def _write_summary(self, statistics, more_chunk_indexes):
        self._write_records(DataEnd(data_section_crc=self._crc))
        summary_start = self._stream.tell()
        offsets = []
        crc = 0

        def put(data):
            nonlocal crc
            crc = zlib.crc32(data, crc)
            self._put(data)

        def group(opcode, records=(), spilled=None, more=b''):
            begin = self._stream.tell()
            for record in records:
                record.write(self._records)
            put(self._records.end())
            if spilled is not None:
                spilled.seek(0)
                while block := spilled.read(1 << 20):
                    put(block)
            put(more)
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=begin,
                                         group_length=self._stream.tell() - begin))

        group(Opcode.SCHEMA, self._schemas)
        group(Opcode.CHANNEL, self._channels)
        group(Opcode.STATISTICS, [statistics])
        group(Opcode.CHUNK_INDEX, spilled=self._chunk_index_file, more=more_chunk_indexes)
        group(Opcode.METADATA_INDEX, self._metadata_indexes)
        offsets_start = self._stream.tell()
        for offset in offsets:
            offset.write(self._records)
        put(self._records.end())
        crc = zlib.crc32(_FOOTER_HEAD.pack(Opcode.FOOTER, 20, summary_start, offsets_start), crc)
        self._write_records(Footer(summary_start=summary_start,
                                   summary_offset_start=offsets_start, summary_crc=crc))
        self._put(MAGIC)


def _span(span, more):
    """Return the (first, last) log times of ``span`` and ``more`` together (``span``: or None)."""
    if span is None:
        return more
    return min(span[0], more[0]), max(span[1], more[1])


def _pieces(held: _Held, size: int) -> Iterator[tuple]:
    """Split a held chunk into chunks of about ``size`` bytes of records, in record order.

    Each is (records, message indexes, first, last log time), as a chunk is written.
    """
    where = {}                              # offset in the chunk -> (channel id, log time)
    for channel_id, records in held.indexes.items():
        for log_time, offset in records:
            where[offset] = (channel_id, log_time)
    begin = 0
    indexes, times = {}, []
    at = 0
    while at < len(held.raw):
        channel_id, log_time = where[at]
        indexes.setdefault(channel_id, []).append((log_time, at - begin))
        times.append(log_time)
        at += 9 + struct.unpack_from('<Q', held.raw, at + 1)[0]
        if at - begin >= size or at >= len(held.raw):
            yield held.raw[begin:at], indexes, min(times), max(times)
            begin, indexes, times = at, {}, []


def _write_all(stream, data):
    """Write all of ``data``: a raw file may take part of it per call."""
    with memoryview(data) as view:
        while view:
            done = stream.write(view)
            view = view[len(view) if done is None else done:]


def _rollback(stream, at):
    """Cut ``stream`` back to ``at`` (a record's start), the room it took given back."""
    stream.truncate(at)
    stream.seek(at)


class _RollBack:
    """A block whose writes are whole or none: on no room, the file is cut back to its start.

    :param stream: the file.
    :param writer: the McapWriter whose data section CRC is put back with the file; None: none.
    """

    def __init__(self, stream, writer=None):
        self._stream = stream
        self._writer = writer

    def __enter__(self):
        self._at = self._stream.tell()
        self._crc = self._writer._crc if self._writer is not None else 0

    def __exit__(self, kind, error, trace):
        if error is not None and no_room(error):
            if self._writer is not None:
                self._writer._cut(self._at, self._crc)
            else:
                _rollback(self._stream, self._at)
        return False
