# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The ``~/viewer`` input: where the viewer stands, for the level of detail (core/lod.py).

A ``geometry_msgs/PointStamped`` in the node's ``world_frame``, from any reliable publisher:
the node subscribes it twice, latched (transient local: a viewer a latched publisher sent
before the node started reaches it) and volatile (``ros2 topic pub`` and other default
publishers, which a transient-local subscription never matches). A latched publisher's message
comes on both and is taken once (:class:`Deliveries`).
"""

import math
from collections import deque
from typing import NamedTuple

import numpy as np
from geometry_msgs.msg import PointStamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from . import cdr

VIEWER_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL,
                        history=HistoryPolicy.KEEP_LAST)
# The second subscription's: volatile matches volatile and transient-local publishers alike.
VIEWER_LIVE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.VOLATILE,
                             history=HistoryPolicy.KEEP_LAST)
VIEWER_TYPE = 'geometry_msgs/msg/PointStamped'
MAX_DISTANCE_M = 1e9        # farther is a unit or encoding error, not a viewer


class ViewerReading(NamedTuple):
    """A ``~/viewer`` message as read: its position, or None and why it was refused."""

    position: np.ndarray | None     # (3,) in the world frame
    stamp_ns: int                   # the header's stamp (0 if it did not decode)
    reason: str                     # '' when accepted


def read_viewer(raw: bytes, world_frame: str) -> ViewerReading:
    """Read a viewer position from CDR bytes; never raises on bad bytes or values.

    Refuses bytes that are no PointStamped, a ``frame_id`` other than ``world_frame`` (the
    node does not look frames up), a non-finite coordinate, or a point farther than
    ``MAX_DISTANCE_M``.

    :param raw: the message's CDR bytes.
    :param world_frame: the node's world frame, the only ``frame_id`` taken.
    """
    try:
        msg = cdr.deserialize(raw, PointStamped)
    except cdr.DECODE_ERRORS as e:
        return ViewerReading(None, 0, f'does not decode ({e})')
    stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
    frame = msg.header.frame_id
    if frame != world_frame:
        return ViewerReading(None, stamp,
                             f'frame_id {frame!r} is not the world frame {world_frame!r}')
    p = (msg.point.x, msg.point.y, msg.point.z)
    if not all(math.isfinite(v) for v in p):
        return ViewerReading(None, stamp, f'a non-finite coordinate {list(p)}')
    if math.hypot(*p) > MAX_DISTANCE_M:
        return ViewerReading(None, stamp, f'farther than {MAX_DISTANCE_M:g} m {list(p)}')
    return ViewerReading(np.array(p, dtype=float), stamp, '')


class Deliveries:
    """Tells a message's first delivery from the same message on another subscription.

    A message is known by its publisher, sequence number and source time (rmw message info).

    :param keep: how many recent messages it remembers.
    """

    def __init__(self, keep: int = 32):
        self._seen = deque(maxlen=keep)

    def first(self, info: dict) -> bool:
        """Tell whether the message ``info`` describes was not delivered before.

        :param info: the message's rmw message info (publisher gid, sequence number, source
            time).
        """
        gid = info.get('publisher_gid')
        if isinstance(gid, dict):
            gid = gid.get('data')
        key = (None if gid is None else bytes(gid), info.get('publication_sequence_number'),
               info.get('source_timestamp'))
        if key[0] is None and key[1] is None and not key[2]:
            return True             # nothing tells it apart: take it
        if key in self._seen:
            return False
        self._seen.append(key)
        return True
