# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A node's session recording (ros/recording.py) from open to close, without a node or DDS.

What the node did with its recording in a dozen of its own methods (issue 49 item 3) is one
object; these hold its lifecycle and every line it says, as the node's tests hold them live.
"""

import errno
import os
from types import SimpleNamespace

from jacket_cloth_ros.recording.reader import read_recording
from jacket_cloth_ros.ros.pipeline import session_topics
from jacket_cloth_ros.ros.recording import NodeRecording, OnClose, RecordingState


class _Logger:
    """The node's logger as the recording uses it: each line kept as (level, text)."""

    def __init__(self):
        self.lines = []

    def info(self, text):
        self.lines.append(('info', text))

    def error(self, text):
        self.lines.append(('error', text))


class _Character:
    """A loaded character as the recording sees it: its pipeline, its channels, its set-up."""

    def __init__(self):
        self.pipeline = SimpleNamespace(recording_problem=None)
        self.diag_recorded = b'said before'
        self.files = []

    def add_to_recording(self, recorder):
        self.files.append(recorder.path)


def _recording(characters=(), alive=None):
    topics = session_topics()
    logger = _Logger()
    recording = NodeRecording({k: topics[k] for k in ('tf', 'diagnostics')}, list(characters),
                              logger, program='jacket_cloth_crowd', alive=alive)
    return recording, logger


def test_a_write_error_stops_the_recording_and_later_writes_are_dropped(tmp_path):
    path = str(tmp_path / 'session.mcap')
    c = _Character()
    recording, logger = _recording([c])
    assert recording.state is RecordingState.OFF
    assert recording.open(path, compression='zstd')
    assert recording.state is RecordingState.RECORDING and recording.problem == ''
    assert logger.lines == [('info', f'recording the session to {path}')]
    assert c.files == [path] and c.diag_recorded is None    # a new file starts with them
    for k in range(3):
        recording.write('/tf', b'\0\1\0\0' + bytes([k]) * 8, 100 + k)

    def broken(*args):
        raise OSError(errno.EIO, 'Input/output error')
    recording.recorder.write = broken
    recording.write('/tf', b'\0\1\0\0', 103)
    assert recording.state is RecordingState.FAILED and recording.recorder is None
    assert recording.problem == 'stopped by a write error ([Errno 5] Input/output error)'
    assert logger.lines[-1] == ('error', 'recording stopped: [Errno 5] Input/output error')
    recording.write('/tf', b'\0\1\0\0', 104)                 # no file: dropped, nothing said
    recording.close()
    assert len(logger.lines) == 2
    # What came before the error is a finished file.
    written = read_recording(path)
    assert written.complete and [m.log_time for m in written.messages] == [100, 101, 102]
    # A record set to it again opens anew: it is no longer being written.
    assert recording.needs_open(path) and 'exists' in recording.refusal(path)


def test_a_full_disk_at_a_write_is_said_by_the_close_not_the_write(tmp_path):
    recording, logger = _recording()
    recording.open(str(tmp_path / 'session.mcap'))

    def full(*args):
        raise OSError(errno.ENOSPC, 'No space left on device')
    recording.recorder.write = full
    recording.write('/tf', b'\0\1\0\0', 1)
    assert recording.state is RecordingState.FAILED and 'No space left' in recording.problem
    assert [level for level, _ in logger.lines] == ['info']


def test_an_existing_path_is_refused_and_left_alone(tmp_path):
    old = tmp_path / 'old.mcap'
    old.write_bytes(b'an earlier session')
    recording, logger = _recording()
    problem = (f'record: {str(old)!r} exists (the node never overwrites a recording): move it '
               'or choose another path')
    assert recording.refusal(str(old)) == problem and recording.refusal('') == ''
    assert not recording.open(str(old))
    assert recording.state is RecordingState.FAILED and recording.problem == problem
    assert logger.lines == [('error', f'{problem}; running without recording')]
    assert old.read_bytes() == b'an earlier session'
    # The file being recorded is the one path that is not refused: set again, it goes on.
    path = str(tmp_path / 'new.mcap')
    assert recording.open(path) and recording.problem == ''
    assert recording.refusal(path) == '' and not recording.needs_open(path)
    recording.close()


def test_a_folder_that_does_not_exist_is_one_line_and_no_recording(tmp_path):
    path = str(tmp_path / 'no' / 'x.mcap')
    recording, logger = _recording()
    assert not recording.open(path)
    assert recording.problem.startswith(f'cannot record to {path!r} (folder ')
    assert logger.lines == [('error', f'{logger.lines[0][1].partition(";")[0]}; running '
                             'without recording')]


def test_a_switch_says_the_close_and_the_node_end_does_not(tmp_path):
    first, second = str(tmp_path / 'a.mcap'), str(tmp_path / 'b.mcap')
    recording, logger = _recording()
    recording.open(first)
    recording.open(second)
    recording.close()
    assert logger.lines == [('info', f'recording the session to {first}'),
                            ('info', f'recording closed: {first}'),
                            ('info', f'recording the session to {second}')]
    assert recording.state is RecordingState.CLOSED
    recording.open('')
    assert recording.state is RecordingState.OFF


def test_a_close_that_fails_after_the_context_is_gone_is_printed(tmp_path, capsys):
    path = str(tmp_path / 'session.mcap')
    recording, logger = _recording(alive=lambda: False)
    recording.open(path)
    # As its writer thread leaves an error the node has not heard yet (a full disk's is said
    # by the count of messages it had no room for instead).
    recording.recorder._error = OSError(errno.EIO, 'Input/output error')
    recording.close(on_close=OnClose.SAY)
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f'jacket_cloth_crowd: recording {path} closed with an error: [Errno 5] '
                   'Input/output error']
    assert recording.state is RecordingState.FAILED
    assert recording.problem == f'{path} closed with an error: [Errno 5] Input/output error'
    assert len(logger.lines) == 1


def test_a_file_replaced_by_another_process_is_saved_and_its_diagnostics_say_so(tmp_path):
    path = tmp_path / 'session.mcap'
    c = _Character()
    recording, logger = _recording()
    recording.open(str(path))
    recording.add_character(c)              # loaded after the open: it joins the open file
    assert c.files == [str(path)] and c.pipeline.recording_problem() == ''
    recording.write('/tf', b'\0\1\0\0', 5)
    recording.check_file()
    assert recording.state is RecordingState.RECORDING
    other = tmp_path / 'other.mcap'
    other.write_bytes(b'not ours')
    os.replace(other, path)
    recording.check_file()
    assert recording.recorder is None and path.read_bytes() == b'not ours'
    saved = tmp_path / 'session.saved.mcap'
    assert [m.log_time for m in read_recording(str(saved)).messages] == [5]
    assert logger.lines[-1] == (
        'error', f'recording {path} was replaced by another process while it was recorded: '
        f'what it holds is saved as {saved}; recording stopped (set record to record again)')
    # The character's diagnostics read the problem from the recording, where it is held.
    assert c.pipeline.recording_problem() == recording.problem == \
        logger.lines[-1][1].removeprefix('recording ')


def test_a_file_whose_channels_cannot_be_added_is_closed_not_left_open(tmp_path, monkeypatch):
    # The file was made, then registering a topic failed: the recording ran on without it
    # but left it open (its writer thread and handle), a file nobody would finish.
    from jacket_cloth_ros.recording.writer import SessionRecorder
    closed = []
    real_close = SessionRecorder.close

    def add_topic(self, *args):
        raise OSError(errno.ENOSPC, 'No space left on device')

    def close(self, *args, **kwargs):
        closed.append(self.path)
        return real_close(self, *args, **kwargs)
    monkeypatch.setattr(SessionRecorder, 'add_topic', add_topic)
    monkeypatch.setattr(SessionRecorder, 'close', close)
    path = str(tmp_path / 'session.mcap')
    recording, logger = _recording()
    assert not recording.open(path)
    assert recording.recorder is None and closed == [path]
    assert not os.path.exists(path)         # a second try at the path is not refused as taken
    assert 'cannot record to' in recording.problem and logger.lines[-1][0] == 'error'


def test_a_chunk_is_compressed_and_written_off_the_thread_that_hands_it_over(tmp_path):
    # The node laid each chunk out, compressed and wrote it in the JointState callback that
    # closed it: most of the callback's CPU with the markers recorded, and a stall a chunk.
    import threading
    recording, _ = _recording()
    recording.open(str(tmp_path / 'session.mcap'), compression='lz4')
    writer = recording.recorder._writer
    compress, threads = writer._compress, []

    def compressed(raw):
        threads.append(threading.current_thread())
        return compress(raw)
    writer._compress = compressed
    for k in range(30):                         # stamps over 2 s: a chunk a second
        recording.write('/tf', b'\0\1\0\0' + bytes([k]) * 8, 10 ** 8 * k)
    recording.close()
    # The close writes the last one and the end itself, as it does on a full disk.
    main = threading.current_thread()
    assert len(threads) == 3 and main not in threads[:-1] and threads[-1] is main
    assert read_recording(str(tmp_path / 'session.mcap')).complete
