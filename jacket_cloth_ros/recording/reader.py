# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Reading ROS 2 MCAP recordings: our own files, rosbag2 bags, files cut short by a kill.

A recording is a plain ``.mcap`` file or a rosbag2 bag directory with MCAP storage (its
``metadata.yaml`` lists the files in order; without it, the folder's ``.mcap`` files by name).
"""

import os
from dataclasses import dataclass, field

import yaml
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel, Message, Metadata, Schema
from mcap.stream_reader import StreamReader

MAGIC = b'\x89MCAP0\r\n'


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


def mcap_files(path):
    """The MCAP files of a recording: the file itself, or a bag directory's files in order."""
    if not os.path.isdir(path):
        if not os.path.exists(path):
            raise RecordingError(f'{path}: no such file or directory')
        return [path]
    meta = os.path.join(path, 'metadata.yaml')
    if os.path.isfile(meta):
        try:
            with open(meta, encoding='utf-8') as f:
                info = yaml.safe_load(f)['rosbag2_bagfile_information']
            storage = info.get('storage_identifier', '')
            if storage != 'mcap':
                raise RecordingError(f'{path}: bag storage is {storage!r}; only mcap is read')
            files = [os.path.join(path, p) for p in info['relative_file_paths']]
        except (yaml.YAMLError, KeyError, TypeError) as e:
            raise RecordingError(f'{path}: unreadable metadata.yaml ({e})') from None
    else:
        files = sorted(os.path.join(path, p) for p in os.listdir(path) if p.endswith('.mcap'))
    if not files:
        raise RecordingError(f'{path}: a directory without .mcap files')
    return files


def read_recording(path, topics=None):
    """Every message (optionally of some topics), metadata and topic types of a recording."""
    out = Recording(path, [])
    for one in mcap_files(path):
        _read_file(one, topics, out)
    return out


class _TopicCounter(dict):
    """Stands in for Recording.messages: counts each message by topic and keeps nothing."""

    def append(self, message):
        self[message.topic] = self.get(message.topic, 0) + 1


def count_messages(path):
    """Messages per topic and whether the recording is complete, streamed: an hour of
    session (gigabytes of /tf and markers) is counted without holding it in memory."""
    out = Recording(path, _TopicCounter())
    for one in mcap_files(path):
        _read_file(one, None, out)
    return dict(out.messages), out.complete


def read_messages(path, topics=None):
    """All messages (optionally of some topics) in file order; (messages, complete)."""
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
        try:
            reader = make_reader(f)
            summary = reader.get_summary()
            if summary is None:
                raise McapError('no summary')
            for schema, channel, message in reader.iter_messages(topics=topics,
                                                                 log_time_order=False):
                out.messages.append(_recorded(schema, channel, message))
            for channel in summary.channels.values():
                schema = summary.schemas.get(channel.schema_id)
                out.topics[channel.topic] = schema.name if schema else ''
            for m in reader.iter_metadata():
                out.metadata[m.name] = dict(m.metadata)
            return
        except Exception:  # noqa: BLE001 - no summary or index (cut short): stream it below
            pass
        # No usable summary (a killed writer): stream the records up to the last readable one.
        f.seek(0)
        schemas, channels = {}, {}
        try:
            for record in StreamReader(f, skip_magic=False).records:
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
        except Exception:  # noqa: BLE001 - everything after the cut is unreadable by design
            out.complete = False


def _recorded(schema, channel, message):
    return RecordedMessage(channel.topic, schema.name if schema else '', message.log_time,
                           message.data)
