# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Reading ROS 2 MCAP recordings: our own files, rosbag2 bags, files cut short by a kill.

A recording is a plain ``.mcap`` file or a rosbag2 bag directory with MCAP storage (its
``metadata.yaml`` lists the files in order; without it, the folder's ``.mcap`` files by name).
"""

import hashlib
import os
import struct
import zlib
from collections.abc import Collection
from dataclasses import dataclass, field

import yaml
from mcap.reader import make_reader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import CRCValidationError, StreamReader

from ..core.config import MAX_YAML_BYTES, bounded_load

MAGIC = b'\x89MCAP0\r\n'
_FOOTER_SIZE = 1 + 8 + 8 + 8 + 4        # opcode, length, summary start, offsets start, CRC


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
        raise RecordingError(f'{path}: a directory without .mcap files')
    return files


def read_recording(path: str, topics: Collection[str] | None = None) -> Recording:
    """Every message (optionally of some topics), metadata and topic types of a recording.

    :param path: the recording, an MCAP file or a bag directory.
    :param topics: the topics whose messages are read; None: every topic.
    """
    out = Recording(path, [])
    for one in mcap_files(path):
        _read_file(one, topics, out)
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


def _read_file(path, topics, out):
    try:
        f = open(path, 'rb')
    except OSError as e:
        raise RecordingError(f'{path}: cannot open ({e.strerror})') from None
    with f:
        if f.read(8) != MAGIC:
            raise RecordingError(f'{path}: not an MCAP file')
        f.seek(0)
        reader = make_reader(f, validate_crcs=True)
        try:
            summary = reader.get_summary()
        except Exception:  # noqa: BLE001 - no footer or summary (cut short): stream it below
            summary = None
        if summary is not None and summary.chunk_indexes:
            _check_summary_crc(f, path)
            # A complete file: whatever fails from here on is damage, never "cut short".
            try:
                for schema, channel, message in reader.iter_messages(topics=topics,
                                                                     log_time_order=False):
                    out.messages.append(_recorded(schema, channel, message))
                for channel in summary.channels.values():
                    schema = summary.schemas.get(channel.schema_id)
                    out.topics[channel.topic] = schema.name if schema else ''
                for m in reader.iter_metadata():
                    out.metadata[m.name] = dict(m.metadata)
            except Exception as e:  # noqa: BLE001 - any kind means the same: a damaged file
                raise _damaged(path, e) from None
            return
        _stream_file(f, path, topics, out)


def _stream_file(f, path, topics, out):
    """Read the records in order, telling a cut file from a damaged one.

    A read that fails at the end of the file is a cut (a killed writer: its readable part is
    kept), one that fails before it is damage.
    """
    size = os.fstat(f.fileno()).st_size
    f.seek(0)
    schemas, channels = {}, {}
    try:
        for record in StreamReader(f, skip_magic=False, validate_crcs=True).records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
                schema = schemas.get(record.schema_id)
                out.topics[record.topic] = schema.name if schema else ''
            elif isinstance(record, Metadata):
                out.metadata[record.name] = dict(record.metadata)
            elif isinstance(record, Message):
                channel = channels.get(record.channel_id)
                if channel is not None and (topics is None or channel.topic in topics):
                    out.messages.append(_recorded(schemas.get(channel.schema_id), channel,
                                                  record))
    except Exception as e:  # noqa: BLE001 - a cut and damage raise alike; where tells them apart
        if f.tell() < size:
            raise _damaged(path, e) from None
        out.complete = False


def _check_summary_crc(f, path):
    """Check the footer's CRC of the summary (MCAP spec); the mcap reader does not check it."""
    f.seek(-(_FOOTER_SIZE + len(MAGIC)), os.SEEK_END)
    footer_at = f.tell()
    summary_start, _, crc = struct.unpack('<QQI', f.read(_FOOTER_SIZE)[9:])
    if crc == 0 or not 0 < summary_start <= footer_at:
        return
    f.seek(summary_start)
    actual = 0
    left = footer_at + _FOOTER_SIZE - 4 - summary_start
    while left > 0:
        block = f.read(min(left, 1 << 20))
        if not block:
            break
        actual = zlib.crc32(block, actual)
        left -= len(block)
    if actual != crc:
        raise RecordingError(f'{path}: damaged file: its summary fails its CRC check; '
                             'nothing read')


def _damaged(path, error):
    if isinstance(error, CRCValidationError):
        return RecordingError(f'{path}: damaged file: a chunk fails its CRC check (its bytes '
                              'changed after it was written); nothing read')
    text = str(error).strip().splitlines()
    return RecordingError(f'{path}: damaged file ({text[0] if text else type(error).__name__});'
                          ' nothing read')


def _recorded(schema, channel, message):
    return RecordedMessage(channel.topic, schema.name if schema else '', message.log_time,
                           message.data)


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
        _read_file(one, (topic,), out)
    return list(out.messages)
