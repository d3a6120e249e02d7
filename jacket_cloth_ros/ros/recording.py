# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A jacket node's session recording: the ``record`` parameter's file, from open to close.

``NodeRecording`` is what the node (ros/node.py) holds of its recording, once: the path asked
for, the open file (recording/writer.py's SessionRecorder), why that path is not being written
(the problem its characters' diagnostics say) and every line said about it. It opens a file
(never over one that exists), writes each message to it, stops on a write error or when
another process replaces or removes the file, and closes it; a failure stops the recording,
never the node. Like mcap's ``Writer``: options by keyword, a choice as an enum.
"""

import contextlib
import enum
import os
import struct
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from ..recording.disk import no_room
from ..recording.writer import SessionRecorder, save_unnamed

if TYPE_CHECKING:           # for the annotations only
    from rclpy.impl.rcutils_logger import RcutilsLogger

    from .character import Character

# A write fails with these: the disk or the file (OSError), a stamp or a size MCAP cannot hold.
WRITE_ERRORS = (OSError, ValueError, struct.error)


class OnClose(enum.Enum):
    """What a clean close says; a close that lost messages or failed is always said."""

    QUIET = 0       # nothing (the node's end)
    SAY = 1         # ``recording closed: PATH`` (``record`` switched live)


class RecordingState(enum.Enum):
    """Where a node's recording is, as ``NodeRecording.state`` tells it."""

    OFF = 0         # ``record`` is empty
    RECORDING = 1   # a file is open and written
    FAILED = 2      # asked for, not written: refused, not opened, or stopped (``problem``)
    CLOSED = 3      # closed cleanly (the node's end)


def overwrite_problem(path: str) -> str:
    """Why the node will not record to ``path``: something is there already ('' if not).

    A recording is never overwritten: a dump of an earlier session's parameters holds its
    ``record``, and starting from it wiped that session.

    :param path: the ``record`` value asked for.
    """
    return _exists(path) if os.path.lexists(path) else ''


def folder_problem(path: str) -> str:
    """Why ``path`` cannot be recorded to: its folder is missing, not one or not ours to write.

    Asked before a live ``record`` is taken: found only at the open, the change was reported
    successful while the node's recording had stopped and no new one started.

    :param path: the ``record`` value asked for (a file, or a bag folder to make).
    """
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.lexists(folder):
        return f'record: folder {folder!r} does not exist: make it first or choose another path'
    if not os.path.isdir(folder):
        return f'record: {folder!r} is not a folder: choose another path'
    if not os.access(folder, os.W_OK | os.X_OK):
        return f'record: folder {folder!r} cannot be written to: choose another path'
    return ''


def _exists(path):
    return (f'record: {path!r} exists (the node never overwrites a recording): move it or '
            'choose another path')


class NodeRecording:
    """A node's recording of its session: one file at a time, its failures said once.

    Every topic the node records is registered at each open: the node's own (``topics``)
    and, for each character loaded, its JointStates, markers and set-up
    (``Character.add_to_recording``); a character loaded later joins by ``add_character``.

    :param topics: the node's own recorded topics by key: (name in the graph, message type,
        offered QoS as rosbag2 records it), as ``pipeline.session_topics`` gives them.
    :param characters: the node's characters (the node's list: a character loaded later is
        in it).
    :param logger: the node's logger, for the lines said about the recording.
    :param program: the executable's name: a line said once the node's context is gone is
        printed to stderr after it.
    :param alive: tells whether the node's context (and rosout) is still up; None: always.
    """

    def __init__(self, topics: dict[str, tuple[str, str, str]],
                 characters: 'Sequence[Character]', logger: 'RcutilsLogger', *,
                 program: str = 'jacket_cloth_node',
                 alive: 'Callable[[], bool] | None' = None):
        self.topics = topics
        self.characters = characters
        self.logger = logger
        self.program = program
        self._alive = alive or (lambda: True)
        self.recorder: 'SessionRecorder | None' = None     # the file being written
        self.asked = ''                 # the record value the open (or failed) file is for
        self.problem = ''               # why that file is not being written, for diagnostics

    @property
    def state(self) -> RecordingState:
        """Where the recording is: off, recording, failed (``problem`` says why) or closed."""
        if self.recorder is not None:
            return RecordingState.RECORDING
        if self.problem:
            return RecordingState.FAILED
        return RecordingState.CLOSED if self.asked else RecordingState.OFF

    def refusal(self, path: str) -> str:
        """Why ``record`` cannot be set to ``path`` ('' if it can): taken, or in no folder.

        Something there that is not ours, or a folder that does not exist: refused with the
        reason, the file being recorded going on. The file being recorded now is the one
        exception: setting it again keeps it going.

        :param path: the ``record`` value asked for ('' turns recording off: always taken).
        """
        if not path or (path == self.asked and self.recorder is not None):
            return ''
        return overwrite_problem(path) or folder_problem(path)

    def needs_open(self, path: str) -> bool:
        """Tell whether ``record`` set to ``path`` opens anew: not the file being recorded.

        The same path again (a params file loaded live) keeps the recording going.

        :param path: the ``record`` value set.
        """
        return path != self.asked or self.recorder is None

    def open(self, path: str, *, compression: str = 'lz4') -> bool:
        """Close the file being recorded, if any, and record to ``path`` ('' : stop there).

        A path that exists is refused, as one made between the check and the open; a file
        that cannot be made leaves the node running without recording. Each says one line
        and sets ``problem``. Returns whether a file is open: the caller may start it with
        what it holds (the last viewer).

        :param path: the ``record`` value: an ``.mcap`` file, else a bag folder.
        :param compression: the file's chunk compression (``record_compression``).
        """
        self.asked = path
        self.problem = ''               # before the close: an error closing the old file stays
        self.close(on_close=OnClose.SAY)    # shown until a new file opens
        if not path:
            return False
        problem = overwrite_problem(path)
        if problem:
            self._refuse(problem)
            return False
        try:
            self.recorder = SessionRecorder(path, compression=compression, background=True)
            for topic, kind, qos in self.topics.values():
                self.recorder.add_topic(topic, kind, qos)
            self.problem = ''
            self.logger.info(f'recording the session to {path}')
            for c in self.characters:       # a new file starts with their diagnostics
                c.diag_recorded = None
        except FileExistsError:         # made since the check: the exclusive create saw it
            self.recorder = None
            self._refuse(_exists(path))
            return False
        except OSError as e:
            if self.recorder is not None:       # made, then a channel failed: let it go
                with contextlib.suppress(Exception):
                    self.recorder.close()
                if path.endswith('.mcap'):      # made a moment ago, with nothing in it
                    with contextlib.suppress(OSError):
                        os.remove(path)
            self.recorder = None
            self.problem = f'cannot record to {path!r} ({e})'
            self.logger.error(f'cannot record to {path!r} ({e}); running without recording')
            return False
        for c in self.characters:
            if c.pipeline is not None:
                c.add_to_recording(self.recorder)
        return True

    def add_character(self, c: 'Character') -> None:
        """Let a character just loaded join: its diagnostics say ``problem``, the file has it.

        :param c: the character, its pipeline loaded.
        """
        c.pipeline.recording_problem = lambda: self.problem
        if self.recorder is not None:
            c.add_to_recording(self.recorder)

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Record one message; dropped when no file is open.

        A write that fails stops the recording (the file closed with what it holds): one
        line, unless the disk is full, which the close says.

        :param topic: a registered topic's name in the graph.
        :param data: the CDR-serialised message.
        :param stamp_ns: its stamp, the log and publish time, ns.
        """
        if self.recorder is None:
            return
        try:
            self.recorder.write(topic, data, stamp_ns)
        except WRITE_ERRORS as e:
            self.problem = f'stopped by a write error ({e})'
            if not no_room(e):          # a full disk: the close says what was kept, in one line
                self.logger.error(f'recording stopped: {e}')
            self.close()

    def check_file(self) -> None:
        """Say, and stop, when another writer replaced or removed the file being recorded.

        Writing on went into a file no path names, lost at its close: what it holds is saved
        under a new name instead.
        """
        recorder = self.recorder
        problem = recorder.file_problem() if recorder is not None else ''
        if not problem:
            return
        kept = recorder.keep_readable()
        self.close()
        try:
            saved = f'what it holds is saved as {save_unnamed(kept, recorder.path)}'
        except OSError as e:
            saved = f'what it held is lost ({e})'
        text = (f'recording {recorder.path} was {problem} by another process while it was '
                f'recorded: {saved}; recording stopped (set record to record again)')
        self.problem = text.removeprefix('recording ')
        self.logger.error(text)

    def close(self, *, on_close: OnClose = OnClose.QUIET) -> None:
        """Close the file being recorded, if any; an error its writer met is one line.

        Closed on a full disk, it says how many messages had no room.

        :param on_close: what a clean close says.
        """
        recorder, self.recorder = self.recorder, None
        if recorder is None:
            return
        try:
            recorder.close()
        except Exception as e:  # noqa: BLE001 - its writer thread's, whatever it was
            self._say_closed(f'recording {recorder.path} closed with an error: {e}')
            return
        if recorder.unwritten or recorder.metadata_lost:
            self._say_closed(f'recording {recorder.path} closed on a full disk: a finished '
                             f'file without its last {recorder.unwritten} messages, which '
                             'had no room' + (', and without metadata.yaml (it is read from '
                                              'its .mcap file)' if recorder.metadata_lost
                                              else ''))
        elif on_close is OnClose.SAY:
            self.logger.info(f'recording closed: {recorder.path}')

    def _refuse(self, problem):
        self.problem = problem
        self.logger.error(f'{problem}; running without recording')

    def _say_closed(self, text):
        """Say why a recording closed short, in diagnostics and in one line."""
        self.problem = text.removeprefix('recording ')
        if self._alive():
            self.logger.error(text)
        else:                           # stopping: rosout is gone, and rcl said so in a line
            print(f'{self.program}: {text}', file=sys.stderr, flush=True)
