# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A session recorder: ROS 2 CDR messages into an MCAP file that rosbag2 and Foxglove open.

Profile ``ros2``, ``ros2msg`` schemas with full definitions, ``cdr`` channels carrying
``offered_qos_profiles`` metadata, statistics, and a ``rosbag2`` metadata record at the end.
``log_time = publish_time = header stamp`` so that the same input gives the same file.
Chunks are flushed about once a second (of stamps), so a killed process leaves a file that is
readable up to its last flushed chunk.
"""

import json
import os
import queue
import threading

import yaml

from ..core.choices import Choice
from .definitions import ros2msg_schema
from .disk import no_room

SESSION_CONFIG = 'jacket_cloth_session'     # the MCAP metadata record of a session's setup
_FOREVER = {'sec': 9223372036, 'nsec': 854775807}
# Chunks close by the once-a-second flush, not by size: the writer keeps an index entry per
# chunk until close (the MCAP summary), and small chunks grew the node's memory by the hour.
CHUNK_BYTES = 8 * 1024 * 1024


class Compression(Choice):
    """MCAP chunk compression (the record_compression parameter).

    lz4 is the node's default: its files are larger than zstd's, but the node compresses the
    closing chunk in its own callback, and lz4 does that in a fraction of zstd's time
    (docs/performance.md).
    """

    NONE = 0
    LZ4 = 1
    ZSTD = 2

    @property
    def mcap_name(self) -> str:
        """The name the MCAP chunk record carries ('' for none)."""
        return '' if self is Compression.NONE else self.name.lower()


def is_bag_folder(path: str | os.PathLike) -> bool:
    """Tell whether a recording path names a rosbag2 bag folder.

    Any path not ending in ``.mcap`` does, as ``ros2 bag record -o NAME`` makes the folder
    NAME.

    :param path: the recording's path.
    """
    return not os.fspath(path).endswith('.mcap')


def qos_profile_yaml(reliable: bool = True, transient_local: bool = False,
                     depth: int = 10) -> str:
    """``offered_qos_profiles`` in the string form of Jazzy and newer.

    :param reliable: reliable, else best effort.
    :param transient_local: transient local (latched), else volatile.
    :param depth: the history's depth (keep last).
    """
    profile = {
        'history': 'keep_last', 'depth': depth,
        'reliability': 'reliable' if reliable else 'best_effort',
        'durability': 'transient_local' if transient_local else 'volatile',
        'deadline': dict(_FOREVER), 'lifespan': dict(_FOREVER), 'liveliness': 'automatic',
        'liveliness_lease_duration': dict(_FOREVER), 'avoid_ros_namespace_conventions': False,
    }
    return yaml.safe_dump([profile], sort_keys=False)


class SessionRecorder:
    """Write CDR-serialised messages to one MCAP file; ``close()`` completes it.

    In the background, the caller still packs each message's head and holds its bytes; a closed
    chunk is laid out, compressed and written by the writer thread. The node and the replay use
    it: compression and file writes release the GIL, so they run on the second core, off the
    input's path. One hand-over per chunk: handing over each message cost the replay more CPU
    in thread switches than the writing itself. A write error then shows at the next chunk or
    at ``close()``, once, and the close ends the file as it does without the thread (a full
    disk's chunks held and written as far as the room goes, the file finished if its end fits).

    :param path: the recording: a ``.mcap`` file, else a bag folder (made here).
    :param flush_period_ns: the span of stamps (ns) after which the open chunk is closed.
    :param final_name: the name the recording will have once moved into place, as its bag
        knows it; None: ``path``'s.
    :param background: whether each closed chunk's compression and write (and every other
        record) is done by a writer thread, in order (the same file).
    :param compression: a Compression name; zstd, the smallest files, unless told (the node
        and the replay pass the record_compression parameter).
    :param exclusive: whether the file must be new, made by an exclusive create (a check
        before it could not see a file made since); False: ``path`` may be a file the caller
        made empty for it (a tool's temporary file).
    """

    def __init__(self, path: str, flush_period_ns: int = 1_000_000_000,
                 final_name: str | None = None, background: bool = False,
                 compression: str = 'zstd', exclusive: bool = True):
        try:            # only recording needs mcap: a node without it runs, unrecorded
            from .mcap_file import McapWriter
        except ImportError as e:
            raise OSError('recording needs the mcap package (rosdep key mcap-ros2-support): '
                          f'{e}') from None
        directory = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(directory):
            raise OSError(f'folder {directory} does not exist')
        codec = Compression.parse(compression, 'compression').mcap_name    # before any file
        self.path = path
        self._folder = None
        file_path = path
        if is_bag_folder(path):
            # As rosbag2 lays a bag out: NAME/NAME_0.mcap and NAME/metadata.yaml.
            os.mkdir(path)              # an existing folder is refused, as ros2 bag does
            self._folder = path
            bag = final_name or os.path.basename(os.path.normpath(path))
            self._name = f'{bag}_0.mcap'
            file_path = os.path.join(path, self._name)
        else:
            self._name = final_name or os.path.basename(path)     # as the bag will know it
        try:
            # Unbuffered: a write the disk has no room for is cut back to the record before
            # it (mcap_file), which a buffer's unwritten tail would make unknowable.
            self._file = open(file_path, 'xb' if exclusive else 'wb', buffering=0)
        except OSError:
            if self._folder is not None:
                os.rmdir(self._folder)          # no empty bag left to refuse the next try
            raise
        self._file_path = file_path
        st = os.fstat(self._file.fileno())
        self._identity = (st.st_dev, st.st_ino)
        self._queue = self._thread = self._error = None
        self._told = False              # whether the caller has heard the writer thread's error
        if background:
            self._queue = queue.SimpleQueue()
            self._thread = threading.Thread(target=self._drain, name='mcap_writer', daemon=True)
            self._thread.start()
        self._writer = McapWriter(self._file, compression=codec, chunk_bytes=CHUNK_BYTES,
                                  run=self._do)
        self._writer.start(profile='ros2', library='jacket_cloth_ros')
        self._channels = {}
        self._schemas = {}
        self._types = {}
        self._qos = {}
        self._flush_period = flush_period_ns
        self._last_flush = None
        self._closed = False
        self.metadata_lost = False      # a bag closed on a full disk without metadata.yaml

    def _do(self, work, *args):
        """Run ``work`` now, or hand it to the writer thread (in order)."""
        if self._queue is None:
            work(*args)
            return
        error = self._error
        if error is not None and not self._told:
            self._told = True           # said once, as a write in the caller's thread says it
            raise error
        if error is None or no_room(error):     # a full disk's chunks are held, not lost
            self._queue.put((work, args))

    def _drain(self):
        while True:
            item = self._queue.get()
            if item is None:
                return
            # After an error the rest is dropped; after a full disk's the writer holds each
            # chunk, which the close writes as far as the room goes.
            if self._error is None or no_room(self._error):
                try:
                    item[0](*item[1])
                except Exception as e:  # noqa: BLE001 - whatever it is, the caller must hear
                    if self._error is None or not no_room(e):
                        self._error, self._told = e, False

    def add_topic(self, topic: str, type_name: str, qos_yaml: str | None = None) -> None:
        """Register a topic's channel (and its type's schema) unless it is registered.

        :param topic: the topic's name.
        :param type_name: its message type (``pkg/msg/Type``).
        :param qos_yaml: its ``offered_qos_profiles``; None: ``qos_profile_yaml()``'s.
        """
        if topic in self._channels:
            return
        if type_name not in self._schemas:
            self._schemas[type_name] = self._writer.register_schema(
                name=type_name, encoding='ros2msg',
                data=ros2msg_schema(type_name).encode())
        qos_yaml = qos_yaml or qos_profile_yaml()
        qos = yaml.safe_load(qos_yaml)
        channel = self._writer.register_channel(
            topic=topic, message_encoding='cdr', schema_id=self._schemas[type_name],
            metadata={'offered_qos_profiles': qos_yaml, 'topic_type_hash': ''})
        # The channel last: a stop (Ctrl-C, SIGTERM) landing in between leaves a topic the
        # close's metadata lists whole, or not at all.
        self._types[topic] = type_name
        self._qos[topic] = qos
        self._channels[topic] = channel

    def write(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Copy ``data`` into the open chunk (the caller may reuse its buffer).

        Logged at ``stamp_ns``, or at 0 for a stamp before it: MCAP times are unsigned, and a
        message stamped before 1970 is kept whole (its header holds its own stamp).

        :param topic: an added topic.
        :param data: the CDR-serialised message.
        :param stamp_ns: its stamp, the log and publish time, ns.
        """
        stamp_ns = max(stamp_ns, 0)
        channel = self._channels[topic]         # positional: this runs for every message
        self._writer.add_message(channel, stamp_ns, data, stamp_ns, self._writer.counts[channel])
        if self._last_flush is None:
            self._last_flush = stamp_ns
        elif abs(stamp_ns - self._last_flush) >= self._flush_period:
            self._writer.flush()
            self._last_flush = stamp_ns

    def add_session_config(self, urdf: str, rig_yaml: str, fabrics_yaml: str,
                           parameters: dict, character: str = '',
                           output_phase: float = 0.0, node_name: str = '',
                           inputs_before: int = 0) -> None:
        """Add what a replay needs besides the inputs: character, rig, fabrics, parameters.

        In a crowd's recording, one per character: ``SESSION_CONFIG/<name>``.

        :param urdf: the character's URDF text.
        :param rig_yaml: the rig file's text.
        :param fabrics_yaml: the fabrics file's text.
        :param parameters: the node's parameter values.
        :param character: in a crowd's recording, the character's name; '' otherwise.
        :param output_phase: a crowd character's output phase (SessionPipeline).
        :param node_name: if given, what its diagnostics status name starts with
            (SessionPipeline's), for the replay's.
        :param inputs_before: the inputs the character took before the file opened (a live
            ``record`` change): its cloth then is not in the file, which a replay says.
        """
        name = f'{SESSION_CONFIG}/{character}' if character else SESSION_CONFIG
        setup = {'urdf': urdf, 'rig_yaml': rig_yaml, 'fabrics_yaml': fabrics_yaml,
                 'parameters_json': json.dumps(parameters, sort_keys=True)}
        if node_name:
            setup['node_name'] = node_name
        if character:
            setup['output_phase'] = repr(output_phase)
        if inputs_before:
            setup['inputs_before'] = str(int(inputs_before))
        self._writer.add_metadata(name, setup)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Add an MCAP metadata record (a crowd replay copies its characters' set-ups).

        :param name: the record's name.
        :param data: its key-value pairs.
        """
        self._writer.add_metadata(name, data)

    def file_problem(self) -> str:
        """Tell whether the file being written is still the one at its path: '' if it is.

        Else 'removed' or 'replaced' (another writer's file there now): what is written goes
        into a file no path names, lost at its close.
        """
        try:
            st = os.stat(self._file_path)
        except FileNotFoundError:
            return 'removed'
        except OSError:
            return ''                   # cannot tell (a folder made unreadable): not a replace
        return '' if (st.st_dev, st.st_ino) == self._identity else 'replaced'

    def keep_readable(self) -> int:
        """Return a descriptor that reads the file being written, after its ``close`` too.

        For a file its path no longer names (``file_problem``): what it holds can still be
        copied out (``save_unnamed``). -1 where the system gives none (no /proc).
        """
        try:
            return os.open(f'/proc/self/fd/{self._file.fileno()}', os.O_RDONLY)
        except OSError:
            return -1

    @property
    def unwritten(self) -> int:
        """How many messages the disk had no room for at the close (0 but on a full disk)."""
        return self._writer.unwritten

    def close(self) -> None:
        """Complete the file: the last chunk, the rosbag2 metadata, the summary.

        On a full disk, what was written before stays readable and the file ends as a finished
        one if its end fits (``unwritten`` then counts the messages left out); if not even
        that fits, the file is cut at its last whole record and the error raised.
        """
        if self._closed:
            return
        self._closed = True
        metadata = []
        try:
            if self._thread is not None:
                self._queue.put(None)
                self._thread.join()
                self._queue = None          # the end is written here, as without the thread
            self._writer.finish(lambda counts, span: {'rosbag2': {
                'serialized_metadata': _last(metadata, self._bag_metadata(counts, span))}})
        finally:
            self._file.close()
        # An error the caller has not heard yet; a full disk's the close has said (unwritten).
        if self._error is not None and not self._told and not no_room(self._error):
            raise self._error
        if self._folder is not None:
            self._write_bag_metadata(metadata[-1])

    def _write_bag_metadata(self, text):
        """Write the bag's metadata.yaml; on a full disk, none rather than a part of one.

        A metadata.yaml cut short makes the whole folder unreadable, while a bag without one
        is read from its .mcap file, which is finished by then.
        """
        path = os.path.join(self._folder, 'metadata.yaml')
        try:
            with open(path, 'w', encoding='utf-8') as f:
                f.write(text)
        except OSError as e:
            if os.path.exists(path):
                os.remove(path)
            if not no_room(e):
                raise
            self.metadata_lost = True

    def _bag_metadata(self, in_file, span):
        """Return the rosbag2 metadata of the messages the file holds (channel id -> count)."""
        start, last = span
        counts = {t: in_file.get(c, 0) for t, c in self._channels.items()}
        # rosbag2's version 9: the QoS profiles as a list, and the files with their ranges.
        meta = {'rosbag2_bagfile_information': {
            'version': 9,
            'storage_identifier': 'mcap',
            'relative_file_paths': [self._name],
            'duration': {'nanoseconds': last - start},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': sum(counts.values()),
            'topics_with_message_count': [
                {'topic_metadata': {'name': t, 'type': self._types[t],
                                    'serialization_format': 'cdr',
                                    'offered_qos_profiles': self._qos[t],
                                    'type_description_hash': ''},
                 'message_count': n} for t, n in counts.items()],
            'compression_format': '', 'compression_mode': '',
            'files': [{'path': self._name,
                       'starting_time': {'nanoseconds_since_epoch': start},
                       'duration': {'nanoseconds': last - start},
                       'message_count': sum(counts.values())}],
            'custom_data': {}, 'ros_distro': os.environ.get('ROS_DISTRO', 'kilted'),
        }}
        return yaml.safe_dump(meta, sort_keys=False)


def save_unnamed(fd: int, path: str) -> str:
    """Copy a recording no path names any more (``keep_readable``'s) next to ``path``.

    As ``<path without .mcap>.saved.mcap`` (``.saved-2.mcap``... if taken), made exclusively
    (never over a file); closes ``fd``. Returns the new file's path; OSError if none was made.

    :param fd: a descriptor reading the recording, from its start.
    :param path: the path it was recorded to (a ``.mcap`` file or a bag folder).
    """
    if fd < 0:
        raise OSError('the system gives no way to read a file no path names')
    try:
        stem = os.path.normpath(path).removesuffix('.mcap')
        for k in range(1, 100):
            target = f'{stem}.saved.mcap' if k == 1 else f'{stem}.saved-{k}.mcap'
            try:
                out = open(target, 'xb')
            except FileExistsError:
                continue
            try:
                with out:
                    os.lseek(fd, 0, os.SEEK_SET)
                    while True:
                        block = os.read(fd, 1 << 20)
                        if not block:
                            break
                        out.write(block)
            except OSError:
                os.remove(target)       # a part of it (a full disk) would pass for the whole
                raise
            return target
        raise OSError(f'{stem}.saved-1...99.mcap all exist')
    finally:
        os.close(fd)


def _last(kept: list, text: str) -> str:
    """Keep ``text`` as the last of ``kept`` and return it (the end may be written twice)."""
    kept.append(text)
    return text
