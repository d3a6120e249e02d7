# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Reading ROS 2 MCAP recordings, tolerant of a file cut short by a kill."""

from dataclasses import dataclass

from mcap.reader import NonSeekingReader, make_reader


class RecordingError(ValueError):
    """A file that cannot be read as a ROS 2 MCAP recording; the message is one line."""


@dataclass
class RecordedMessage:
    topic: str
    type_name: str
    log_time: int
    data: bytes


def _recorded(schema, channel, message):
    return RecordedMessage(channel.topic, schema.name if schema else '', message.log_time,
                           message.data)


def read_messages(path, topics=None):
    """All messages (optionally of some topics) in file order; (messages, complete)."""
    try:
        f = open(path, 'rb')
    except OSError as e:
        raise RecordingError(f'{path}: cannot open ({e.strerror})') from None
    out = []
    with f:
        magic = f.read(8)
        if magic != b'\x89MCAP0\r\n':
            raise RecordingError(f'{path}: not an MCAP file')
        f.seek(0)
        try:
            for record in make_reader(f).iter_messages(topics=topics):
                out.append(_recorded(*record))
            return out, True
        except Exception:  # noqa: BLE001 - no summary or index (cut short): stream it below
            pass
        # No usable summary (killed writer): stream the records up to the last readable chunk.
        f.seek(0)
        out = []
        stream = NonSeekingReader(f).iter_messages(log_time_order=False)
        try:
            for record in stream:
                if topics is None or record[1].topic in topics:
                    out.append(_recorded(*record))
        except Exception:  # noqa: BLE001 - everything after the cut is unreadable by design
            return out, False
        return out, True
