# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Reading ROS 2 MCAP recordings: our own files, rosbag2 bags, files cut short by a kill.

A recording is a plain ``.mcap`` file or a rosbag2 bag directory with MCAP storage (its
``metadata.yaml`` lists the files in order; without it, the folder's ``.mcap`` files by name).
"""

import hashlib
import io
import os
import struct
import zlib
from collections.abc import Callable, Collection
from dataclasses import dataclass, field

import yaml
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Metadata, Schema

from ..core.config import (
    MAX_YAML_BYTES, ConfigError, bounded_load, regular_file_or_refuse, shown)

try:
    import lz4.frame
except ImportError:             # the codecs are optional, as in the mcap package
    lz4 = None
try:
    import zstandard
except ImportError:
    zstandard = None

MAGIC = b'\x89MCAP0\r\n'
_FOOTER_SIZE = 1 + 8 + 8 + 8 + 4        # opcode, length, summary start, offsets start, CRC
_FOOTER_START = struct.pack('<BQ', Opcode.FOOTER, 20)
_RECORD_HEAD = struct.Struct('<BQ')     # opcode, length
_MESSAGE_HEAD = struct.Struct('<HIQQ')  # channel, sequence, log time, publish time
_CHUNK_FIELDS = struct.Struct('<QQQI')  # start, end, uncompressed size, uncompressed CRC
# A chunk's records decompressed, and any record read whole: the node's chunks close at a
# few MB (writer.py); this bounds what a file's claims can make the reader allocate.
MAX_CHUNK_BYTES = 256 << 20
MAX_RECORD_BYTES = MAX_CHUNK_BYTES + 4096
_READ = {Opcode.HEADER, Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.CHUNK,
         Opcode.METADATA, Opcode.DATA_END, Opcode.FOOTER}
_IN_CHUNKS = {Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE}
_KNOWN = set(Opcode)
# Records of kinds no writer of ours or rosbag2's writes: a few are the MCAP spec's future;
# a file of nothing else is garbage that would be walked 9 bytes at a time.
MAX_UNKNOWN_RECORDS = 1 << 16
NO_MESSAGES = ('',)         # a topic filter no message passes: a recording's topics alone


class RecordingError(ValueError):
    """A file that cannot be read as a ROS 2 MCAP recording; the message is one line."""


@dataclass
class RecordedMessage:
    topic: str
    type_name: str
    log_time: int
    data: bytes


@dataclass
class Recording:
    path: str
    messages: list                      # RecordedMessage, in file order
    metadata: dict = field(default_factory=dict)     # name -> {key: value}
    topics: dict = field(default_factory=dict)       # topic -> type name
    complete: bool = True               # False: cut short, the readable part is here


def mcap_files(path: str) -> list[str]:
    """Return a recording's MCAP files: the file itself, or a bag directory's files in order.

    :param path: the recording, an MCAP file or a bag directory.
    """
    if not os.path.isdir(path):
        if not os.path.exists(path):
            raise RecordingError(f'{path}: no such file or directory')
        return [path]
    meta = os.path.join(path, 'metadata.yaml')
    if os.path.isfile(meta):
        try:
            with open(meta, encoding='utf-8') as f:
                info = bounded_load(f.read(MAX_YAML_BYTES + 1))['rosbag2_bagfile_information']
            storage = info.get('storage_identifier', '')
            if storage != 'mcap':
                raise RecordingError(f'{path}: bag storage is {storage!r}; only mcap is read')
            files = [os.path.join(path, p) for p in info['relative_file_paths']]
        except (OSError, ValueError, yaml.YAMLError, KeyError, TypeError, AttributeError) as e:
            if isinstance(e, RecordingError):
                raise
            # The YAML parser's messages span lines (a caret under the bad column): one line.
            text = ' '.join(str(e).split()) or type(e).__name__
            if isinstance(e, KeyError):
                text = f'no {text}'
            raise RecordingError(f'{meta}: not a rosbag2 metadata file ({text})') from None
    else:
        files = sorted(os.path.join(path, p) for p in os.listdir(path) if p.endswith('.mcap'))
    if not files:
        raise RecordingError(f'{meta}: lists no files (relative_file_paths is empty)'
                             if os.path.isfile(meta) else
                             f'{path}: a directory without .mcap files')
    seen = {}
    for one in files:           # by real path: a link or ../ naming a listed file again too
        real = os.path.realpath(one)
        if real in seen:
            raise RecordingError(_twice(path, meta, seen[real], one))
        seen[real] = one
    return files


def _twice(path, meta, first, again):
    """Say that a bag reaches one file twice, naming what lists it: metadata.yaml or the folder."""
    if os.path.isfile(meta):
        return f'{meta}: lists {first} twice (as {again}); each file of a bag is read once'
    return (f'{path}: holds {first} twice ({again} is a link to it); each file of a bag is '
            'read once')


def read_recording(path: str, topics: Collection[str] | None = None,
                   kinds: Collection[str] | None = None) -> Recording:
    """Every message (optionally of some topics or types), metadata and topic types.

    :param path: the recording, an MCAP file or a bag directory.
    :param topics: topics whose messages are read.
    :param kinds: message types (``sensor_msgs/msg/JointState``) whose messages are read too.
        Neither given: every message.
    """
    out = Recording(path, [])
    for one in mcap_files(path):
        _read_file(one, _wanted(topics, kinds), out)
    return out


def _wanted(topics, kinds):
    """Return whether a message of (topic, type) is read; None: every message."""
    if topics is None and kinds is None:
        return None
    topics, kinds = frozenset(topics or ()), frozenset(kinds or ())
    return lambda topic, kind: topic in topics or kind in kinds


class _Handed:
    """Stands in for Recording.messages: hands each message on and keeps none."""

    def __init__(self, take):
        self.append = take


def each_message(path: str, take: Callable[[RecordedMessage], None],
                 topics: Collection[str] | None = None,
                 kinds: Collection[str] | None = None) -> Recording:
    """Hand each message (optionally of some topics or types) to ``take``, in file order.

    Nothing is held here: a caller keeps what it needs of a session hours long.

    :param path: the recording, an MCAP file or a bag directory.
    :param take: called with each RecordedMessage read.
    :param topics: topics whose messages are read.
    :param kinds: message types whose messages are read too. Neither given: every message.
    :returns: the recording's metadata, topics and completeness, with no messages.
    """
    out = Recording(path, _Handed(take))
    for one in mcap_files(path):
        _read_file(one, _wanted(topics, kinds), out)
    out.messages = []
    return out


class _TopicCounter(dict):
    """Stands in for Recording.messages: counts each message by topic and keeps nothing."""

    def append(self, message):
        self[message.topic] = self.get(message.topic, 0) + 1


def count_messages(path: str) -> tuple[dict[str, int], bool]:
    """Count messages per topic and tell whether the recording is complete, streamed.

    An hour of session (gigabytes of /tf and markers) is counted without holding it in memory.

    :param path: the recording, an MCAP file or a bag directory.
    """
    out = Recording(path, _TopicCounter())
    for one in mcap_files(path):
        _read_file(one, None, out)
    return dict(out.messages), out.complete


def read_messages(path: str,
                  topics: Collection[str] | None = None) -> tuple[list[RecordedMessage], bool]:
    """All messages (optionally of some topics) in file order; (messages, complete).

    :param path: the recording, an MCAP file or a bag directory.
    :param topics: the topics whose messages are read; None: every topic.
    """
    rec = read_recording(path, topics)
    return rec.messages, rec.complete


def _read_file(path, wanted, out):
    f = _open_recording(path)
    with f:
        size = os.fstat(f.fileno()).st_size
        if f.read(8) != MAGIC:
            raise RecordingError(f'{path}: not an MCAP file')
        scan = _Scan(f, size, wanted, out)
        try:
            scan.run()
        except _Short as e:
            if scan.finished:       # its footer is there: a finished file with a bad length
                raise RecordingError(f'{path}: damaged file ({e}); nothing read') from None
            out.complete = False    # a killed writer's file: its readable part is kept
        except _Damage as e:
            raise RecordingError(f'{path}: damaged file ({e}); nothing read') from None
        except _Foreign as e:
            raise RecordingError(f'{path}: {e}') from None


def _open_recording(path):
    """Open a recording file for reading, refusing what is not a regular file unopened."""
    try:
        regular_file_or_refuse(path, 'recording')
        return open(path, 'rb')
    except OSError as e:
        raise RecordingError(f'{path}: cannot open ({e.strerror})') from None
    except ConfigError as e:
        raise RecordingError(str(e)) from None


class _Short(Exception):
    """The file ends inside a record."""


class _Damage(Exception):
    """A record that no MCAP writer writes; the message is one line."""


class _Foreign(Exception):
    """A message whose channel declares an encoding other than CDR; the message is one line."""


class _Scan:
    """One pass over an MCAP file's records, in file order, bounded by the file's bytes.

    Each record's length is checked against the bytes left before anything is read; a chunk
    is decompressed to its declared size at most, itself at most MAX_CHUNK_BYTES, so the
    memory beyond the messages kept is a record and a chunk.
    """

    def __init__(self, f, size, wanted, out):
        self.f, self.size, self.wanted, self.out = f, size, wanted, out
        self.crc = zlib.crc32(MAGIC)            # of the data section, then of the summary
        self.schemas, self.channels = {}, {}
        self.foreign = {}                       # channel id -> why its messages are not read
        self.unknown = 0
        self.finished = self._has_footer()

    def _has_footer(self):
        """Tell whether the file ends as a finished MCAP does: a footer record, the magic."""
        if self.size < 2 * len(MAGIC) + _FOOTER_SIZE:
            return False
        self.f.seek(self.size - len(MAGIC) - _FOOTER_SIZE)
        tail = self.f.read(_FOOTER_SIZE + len(MAGIC))
        self.f.seek(len(MAGIC))
        return tail[-len(MAGIC):] == MAGIC and tail[:9] == _FOOTER_START

    def _read(self, n):
        data = self.f.read(n)
        if len(data) < n:
            raise _Short(f'it ends inside a record at byte {self.f.tell()}')
        return data

    def _record(self, kinds):
        """Return (opcode, head, body, offset) of the next record; the body only of ``kinds``.

        Other records are read in blocks for the CRC only.
        """
        at = self.f.tell()
        head = self._read(9)
        opcode, length = _RECORD_HEAD.unpack(head)
        if opcode == 0:
            raise _Damage(f'a record of opcode 0 at byte {at}')
        if opcode not in _KNOWN:
            self.unknown += 1
            if self.unknown > MAX_UNKNOWN_RECORDS:
                raise _Damage(f'over {MAX_UNKNOWN_RECORDS} records of unknown kinds, the last '
                              f'at byte {at}')
        if length > self.size - at - 9:
            raise _Short(f'a record at byte {at} runs past the end of the file')
        self.crc = zlib.crc32(head, self.crc)
        if opcode in kinds:
            if length > MAX_RECORD_BYTES:
                raise _Damage(f'a record of {length} bytes at byte {at}, over the '
                              f'{MAX_RECORD_BYTES} one may hold here')
            body = self._read(length)
            self.crc = zlib.crc32(body, self.crc)
            return opcode, head, body, at
        while length:
            block = self._read(min(length, 1 << 20))
            self.crc = zlib.crc32(block, self.crc)
            length -= len(block)
        return opcode, head, None, at

    def run(self):
        """Read the data section into the recording, then check the summary and footer."""
        first = self.f.read(1)
        if not first:
            raise _Short('it ends after its magic')
        if first != bytes([Opcode.HEADER]):
            raise _Damage('no header record after its magic')
        self.f.seek(len(MAGIC))
        self._record(_READ)
        while True:
            before = self.crc
            opcode, _, body, at = self._record(_READ)
            if opcode == Opcode.FOOTER:
                raise _Damage(f'a footer at byte {at} before its data section ends')
            try:
                if opcode == Opcode.DATA_END:
                    expected = struct.unpack_from('<I', body)[0]
                    break
                self._take(opcode, body)
            except (_Damage, _Short, _Foreign):
                raise
            except Exception as e:  # noqa: BLE001 - a record that does not parse, of any kind
                raise _Damage(f'a record at byte {at} does not parse ({_text(e)})') from None
        if expected and expected != before:
            raise _Damage('its data section fails its CRC check: a byte of its set-up, '
                          'channels or messages changed after it was written')
        self._summary()

    def _summary(self):
        """Walk the summary's records to the footer; check its offsets, CRC and the end."""
        start = self.f.tell()
        self.crc = 0
        opcode = None
        while opcode != Opcode.FOOTER:
            before = self.crc
            opcode, head, body, at = self._record({Opcode.FOOTER})
        if len(body) != 20:
            raise _Damage(f'its footer at byte {at} is {len(body)} bytes, not 20')
        summary_start, _, crc = struct.unpack('<QQI', body)
        if summary_start not in (0, start):
            raise _Damage(f'its footer puts the summary at byte {summary_start}, not {start}')
        if crc and crc != zlib.crc32(body[:16], zlib.crc32(head, before)):
            raise _Damage('its summary fails its CRC check')
        tail = self.f.read(len(MAGIC) + 1)
        if len(tail) < len(MAGIC) and MAGIC.startswith(tail):
            raise _Short()          # cut inside its closing magic: every message is there
        if tail != MAGIC:
            raise _Damage('its footer is not followed by the closing magic alone')

    def _take(self, opcode, body):
        if opcode == Opcode.CHUNK:
            for inner, record in _chunk_records(body):
                if inner in _IN_CHUNKS:
                    self._take(inner, record)
        elif opcode == Opcode.MESSAGE:
            channel_id, _, log_time, _ = _MESSAGE_HEAD.unpack_from(body)
            channel = self.channels.get(channel_id)
            if channel is not None and (self.wanted is None or self.wanted(*channel)):
                if channel_id in self.foreign:
                    raise _Foreign(self.foreign[channel_id])
                self.out.messages.append(RecordedMessage(channel[0], channel[1], log_time,
                                                         bytes(body[_MESSAGE_HEAD.size:])))
        elif opcode == Opcode.SCHEMA:
            schema = Schema.read(_stream(body))
            self.schemas[schema.id] = schema.name
        elif opcode == Opcode.CHANNEL:
            channel = Channel.read(_stream(body))
            kind = self.schemas.get(channel.schema_id, '')
            self.channels[channel.id] = (channel.topic, kind)
            self.out.topics[channel.topic] = kind
            if channel.message_encoding != 'cdr':
                # Its messages are not CDR bytes whatever its type says: decoded as CDR they
                # were garbage read as values, or a refusal that blamed the bytes.
                self.foreign[channel.id] = (
                    f'{channel.topic} ({kind or "no schema"}) is declared '
                    f'{shown(channel.message_encoding)}-encoded; only cdr (ROS 2) messages '
                    'are read')
            else:
                self.foreign.pop(channel.id, None)
        elif opcode == Opcode.METADATA:
            metadata = Metadata.read(_stream(body))
            self.out.metadata[metadata.name] = dict(metadata.metadata)


def _stream(body):
    return ReadDataStream(io.BytesIO(body))


def _text(error):
    text = str(error).strip().splitlines()
    return text[0] if text else type(error).__name__


def _chunk_records(body):
    """Yield (opcode, body) of a chunk's records, decompressed within its declared size."""
    _, _, declared, crc = _CHUNK_FIELDS.unpack_from(body)
    at = _CHUNK_FIELDS.size
    (name_length,) = struct.unpack_from('<I', body, at)
    compression = bytes(body[at + 4:at + 4 + name_length]).decode()
    at += 4 + name_length
    (packed_length,) = struct.unpack_from('<Q', body, at)
    packed = memoryview(body)[at + 8:at + 8 + packed_length]
    if len(packed) != packed_length:
        raise _Damage(f'a chunk holds {len(packed)} bytes where it says {packed_length}')
    if declared > MAX_CHUNK_BYTES:
        raise _Damage(f'a chunk says it holds {declared} bytes decompressed, over the '
                      f'{MAX_CHUNK_BYTES} a recording chunk may hold')
    raw = _decompress(compression, packed, declared)
    if len(raw) > declared:
        raise _Damage(f'a chunk decompresses to more than the {declared} bytes it says')
    if len(raw) < declared:
        raise _Damage(f'a chunk decompresses to {len(raw)} bytes where it says {declared}')
    if crc and zlib.crc32(raw) != crc:
        raise _Damage('a chunk fails its CRC check (its bytes changed after it was written)')
    view = memoryview(raw)
    at = 0
    while at < declared:
        if declared - at < 9:
            raise _Damage('a chunk ends inside a record')
        opcode, length = _RECORD_HEAD.unpack_from(view, at)
        if opcode == 0:
            raise _Damage('a chunk holds a record of opcode 0')
        if length > declared - at - 9:
            raise _Damage('a chunk holds a record longer than the chunk')
        yield opcode, view[at + 9:at + 9 + length]
        at += 9 + length


def _decompress(compression, packed, declared):
    """Return a chunk's records: at most one byte more than ``declared`` is ever made."""
    limit = declared + 1
    if compression == '':
        return packed
    if compression == 'zstd':
        if zstandard is None:
            raise _Damage('a zstd chunk and no zstandard package to read it')
        try:
            with zstandard.ZstdDecompressor().stream_reader(
                    io.BytesIO(packed), read_across_frames=True) as reader:
                out = bytearray()
                while len(out) < limit:         # a read may give less than asked
                    block = reader.read(limit - len(out))
                    if not block:
                        break
                    out += block
                return out
        except zstandard.ZstdError as e:
            raise _Damage(f'a zstd chunk does not decompress ({_text(e)})') from None
    if compression == 'lz4':
        if lz4 is None:
            raise _Damage('an lz4 chunk and no lz4 package to read it')
        try:
            return lz4.frame.LZ4FrameDecompressor().decompress(bytes(packed), max_length=limit)
        except RuntimeError as e:
            raise _Damage(f'an lz4 chunk does not decompress ({_text(e)})') from None
    raise _Damage(f'a chunk of unknown compression {compression!r}')


class _Digests(list):
    """Stands in for Recording.messages: keeps a digest of each message's bytes, not the bytes."""

    def append(self, message):
        super().append(message_digest(message.data))


def message_digest(data: bytes) -> bytes:
    """Return the digest :func:`message_digests` keeps of a message's bytes.

    :param data: the message's serialized bytes.
    """
    return hashlib.blake2b(bytes(data), digest_size=16).digest()


def message_digests(path: str, topic: str) -> list[bytes]:
    """Return a digest of each message on ``topic``, in file order, read as a stream.

    A session's /tf compared message by message without holding it (hours of it are
    gigabytes).

    :param path: an MCAP file or a rosbag2 bag directory.
    :param topic: the topic.
    """
    out = Recording(path, _Digests())
    for one in mcap_files(path):
        _read_file(one, _wanted((topic,), None), out)
    return list(out.messages)
