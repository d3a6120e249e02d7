# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth play``: a recording's JointStates live, where ``ros2 bag play`` is absent.

An imported capture or a node's session drives the node, RViz or Foxglove on any machine with
the wheels: the messages keep their recorded pace and content (names and positions), stamped
from now, and the character's URDF goes on ``robot_description``.
"""

from collections.abc import Iterator

import numpy as np

from ..core.skeleton import load_skeleton, skeleton_from
from ..recording.reader import RecordingError, read_recording
from ..recording.writer import SESSION_CONFIG
from ..ros.cdr import DECODE_ERRORS, JointStateReader
from .session import JOINT_STATE, joint_state_topic


def recorded_inputs(path: str, topic: str | None = None,
                    urdf_path: str | None = None) -> tuple[str | None, Iterator, str]:
    """Read a recording's JointStates for :func:`live.play_live`.

    :param path: an MCAP file or a rosbag2 bag directory.
    :param topic: the JointState topic; None takes the only one (or ``/joint_states``).
    :param urdf_path: a URDF file for ``robot_description``; None takes the recorded one.
    :returns: (URDF text or None, ``(offset_ns, names, positions)`` of each message in file
        order, offsets from the first header stamp, a line saying what plays).
    :raises RecordingError: no JointState, or one that does not decode or holds a position
        that is not a finite number (named by its stamp), before anything is published.
    :raises ConfigError: ``urdf_path``, or the recording's own URDF, is no character's URDF,
        refused as ``motion --urdf`` refuses it.
    """
    # Loaded as every other tool loads a character, so a file that is no URDF, or one whose
    # links form a cycle, is refused before the node is up, not published.
    urdf = load_skeleton(urdf_path).urdf_xml if urdf_path else None
    recording = read_recording(path, kinds=(JOINT_STATE,))
    topic = joint_state_topic(recording, topic)
    if not urdf_path:
        urdf = recording.metadata.get(SESSION_CONFIG, {}).get('urdf') or None
        if urdf:            # the recording's own, checked as a given one is
            skeleton_from(urdf, f'{path}: its recorded URDF')
    messages = [m for m in recording.messages if m.topic == topic]
    if not messages:
        raise RecordingError(f'{path}: no message on {topic}')
    reader = JointStateReader()
    contents = []
    for m in messages:
        try:
            contents.append(reader.read(m.data))
        except DECODE_ERRORS as e:
            raise RecordingError(f'{path}: a {topic} message logged at {m.log_time} ns does '
                                 f'not decode as JointState ({e})') from None
        # Refused whole, before the first is sent: a NaN takes the character nowhere, and a
        # recording stopped halfway would leave its subscribers on a pose it never meant.
        bad = ~np.isfinite(contents[-1].position)
        if bad.any():
            j = int(np.argmax(bad))
            joint = contents[-1].name[j] if j < len(contents[-1].name) else f'position {j}'
            raise RecordingError(f'{path}: a {topic} message logged at {m.log_time} ns gives '
                                 f'{joint} {contents[-1].position[j]}, not a finite number: '
                                 'nothing was published')
    first = contents[0].stamp_ns
    span = (max(c.stamp_ns for c in contents) - first) * 1e-9
    what = f'{len(contents)} JointStates of {topic} over {span:.1f} s'
    return urdf, ((c.stamp_ns - first, c.name, c.position) for c in contents), what
