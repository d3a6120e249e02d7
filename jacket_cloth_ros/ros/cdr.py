# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""CDR (XCDR1, little endian) encoding of the node's output messages, padding zeroed.

Why not rclpy's serialize_message: it leaves alignment padding uninitialised (two
serialisations of the same /tf differ in their padding), so a recorded session could never be
byte-identical. Encoding straight from the simulation's arrays also
skips building thousands of message objects per second. The node publishes these bytes as they
are (``Publisher.publish`` takes serialised bytes) and records the same bytes.
"""

import dataclasses
import struct
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..core.compiled import njit

if TYPE_CHECKING:           # for the annotations only: messages builds on this module
    from .messages import MarkerSpec

_HEADER = b'\x00\x01\x00\x00'        # CDR_LE encapsulation


class CdrWriter:
    """Appends CDR fields; alignment is relative to the end of the encapsulation header."""

    def __init__(self):
        self.buf = bytearray(_HEADER)

    def align(self, n: int) -> None:
        """Pad with zeros to the next multiple of ``n`` bytes.

        :param n: the alignment, bytes.
        """
        pad = -(len(self.buf) - 4) % n
        if pad:
            self.buf += bytes(pad)

    def u8(self, v: int) -> None:
        """Add an unsigned byte.

        :param v: the value; taken modulo 256.
        """
        self.buf.append(int(v) & 0xFF)

    def i32(self, v: int) -> None:
        """Add a signed 32-bit integer, aligned.

        :param v: the value.
        """
        self.align(4)
        self.buf += struct.pack('<i', v)

    def u32(self, v: int) -> None:
        """Add an unsigned 32-bit integer, aligned.

        :param v: the value.
        """
        self.align(4)
        self.buf += struct.pack('<I', v)

    def f32s(self, values: Sequence[float]) -> None:
        """Add float32 values, aligned once.

        :param values: the values, in order.
        """
        self.align(4)
        self.buf += struct.pack(f'<{len(values)}f', *values)

    def f64s(self, values: Sequence[float]) -> None:
        """Add float64 values, aligned once.

        :param values: the values, in order.
        """
        self.align(8)
        self.buf += struct.pack(f'<{len(values)}d', *values)

    def f64_array(self, array: np.ndarray) -> None:
        """Add a block of float64 (any shape, row-major), aligned once: a sequence's elements.

        :param array: the values, any shape, written row-major.
        """
        self.align(8)
        self.buf += np.ascontiguousarray(array, dtype='<f8').tobytes()

    def string(self, s: str) -> None:
        """Add a string: its length with the terminating zero, the UTF-8 bytes and the zero.

        :param s: the text.
        """
        b = s.encode()
        self.u32(len(b) + 1)
        self.buf += b
        self.buf.append(0)

    def stamp(self, stamp_ns: int) -> None:
        """Add a builtin_interfaces/Time.

        :param stamp_ns: the time, ns.
        """
        self.i32(int(stamp_ns // 1_000_000_000))
        self.u32(int(stamp_ns % 1_000_000_000))

    def header(self, stamp_ns: int, frame_id: str) -> None:
        """Add a std_msgs/Header.

        :param stamp_ns: its stamp, ns.
        :param frame_id: its frame.
        """
        self.stamp(stamp_ns)
        self.string(frame_id)

    def bytes(self) -> bytes:
        return bytes(self.buf)


def joint_state(stamp_ns: int, names: Sequence[str], positions: Sequence[float],
                frame_id: str = '') -> bytes:
    """Encode a sensor_msgs/JointState with names and positions (no velocity, no effort).

    Padding is zeroed and nothing follows the last field: rclpy's serializer leaves its
    padding uninitialised and appends bytes that strict readers reject.

    :param stamp_ns: the header stamp, ns.
    :param names: joint names, in the order of ``positions``.
    :param positions: one value per name (rad or m).
    :param frame_id: the header frame.
    """
    w = CdrWriter()
    w.header(stamp_ns, frame_id)
    w.u32(len(names))
    for name in names:
        w.string(name)
    w.u32(len(positions))
    if len(positions):
        w.f64_array(positions)
    w.u32(0)                        # velocity
    w.u32(0)                        # effort
    return w.bytes()


def parameter_event(stamp_ns: int, node: str, changed: Sequence) -> bytes:
    """Encode an rcl_interfaces/ParameterEvent with changed parameters.

    Padding zeroed and nothing after the last field (see :func:`joint_state`).

    :param stamp_ns: the event's stamp, ns.
    :param node: the full name of the node whose parameters changed.
    :param changed: the changed rcl_interfaces/Parameter messages.
    """
    w = CdrWriter()
    w.stamp(stamp_ns)
    w.string(node)
    w.u32(0)                        # new_parameters
    w.u32(len(changed))
    for p in changed:
        v = p.value
        w.string(p.name)
        w.u8(v.type)
        w.u8(bool(v.bool_value))
        w.align(8)
        w.buf += struct.pack('<qd', int(v.integer_value), float(v.double_value))
        w.string(v.string_value)
        w.u32(len(v.byte_array_value))
        w.buf += b''.join(bytes(b) if isinstance(b, bytes) else bytes([b])
                          for b in v.byte_array_value)
        w.u32(len(v.bool_array_value))
        w.buf += bytes(bool(b) for b in v.bool_array_value)
        for values, code in ((v.integer_array_value, 'q'), (v.double_array_value, 'd')):
            w.u32(len(values))
            if len(values):
                w.align(8)
                w.buf += struct.pack(f'<{len(values)}{code}', *values)
        w.u32(len(v.string_array_value))
        for text in v.string_array_value:
            w.string(text)
    w.u32(0)                        # deleted_parameters
    return w.bytes()


def tf_message(names: Sequence[str], parents: Sequence[str], translations: np.ndarray,
               quaternions: np.ndarray, stamp_ns: int, prefix: str = '') -> bytes:
    """tf2_msgs/TFMessage: one TransformStamped per bone (field by field; see TfTemplate).

    :param names: the bones' frame names.
    :param parents: each bone's parent frame.
    :param translations: (bones, 3) metres, each bone in its parent's frame.
    :param quaternions: (bones, 4) x, y, z, w.
    :param stamp_ns: every transform's stamp, ns.
    :param prefix: put before every frame name (as robot_state_publisher's ``frame_prefix``).
    """
    w = CdrWriter()
    w.u32(len(names))
    for name, parent, t, q in zip(names, parents, translations.tolist(), quaternions.tolist()):
        w.header(stamp_ns, parent)
        w.string(prefix + name)
        w.f64s(t + q)
    return w.bytes()


class _Template:
    """Message bytes laid out once; each message writes its varying numbers into place.

    CDR aligns every double to 8 and every 32-bit integer to 4 bytes after the 4-byte
    encapsulation header, so views from there reach each field by a plain index.
    """

    def __init__(self, w, stamp_at):
        # Placed so that those views are aligned: a scatter into an unaligned view is several
        # times slower.
        size = len(w.buf)
        store = np.zeros(size + 8, dtype=np.uint8)
        start = -(store.ctypes.data + 4) % 8
        self._u8 = store[start:start + size]
        self._u8[:] = np.frombuffer(w.buf, dtype=np.uint8)
        self._f64 = self._u8[4:4 + (size - 4) // 8 * 8].view('<f8')
        self._u32 = self._u8[4:4 + (size - 4) // 4 * 4].view('<u4')
        self._stamp_at = ((np.asarray(stamp_at) - 4) // 4)[:, None] + np.arange(2)  # sec, nanosec

    @staticmethod
    def _f64_at(byte_at, count):
        """Return ``count`` doubles' indices from byte ``byte_at`` (8-aligned after the header)."""
        return (byte_at - 4) // 8 + np.arange(count)

    def _bytes(self, stamp_ns):
        put_stamp(self._u32, self._stamp_at, stamp_ns)
        return self._u8.tobytes()


class TfTemplate(_Template):
    """The bytes of a TFMessage whose bone names and parents never change, laid out once.

    Each message then only writes its stamps and poses into place instead of hundreds of small
    appends, which were a large share of an input. The bytes equal :func:`tf_message`'s.

    :param names: the bones' frame names.
    :param parents: each bone's parent frame.
    :param prefix: put before every frame name (as robot_state_publisher's ``frame_prefix``).
    """

    def __init__(self, names: Sequence[str], parents: Sequence[str], prefix: str = ''):
        w = CdrWriter()
        w.u32(len(names))
        stamps, poses = [], []
        for name, parent in zip(names, parents):
            w.align(4)
            stamps.append(len(w.buf))
            w.header(0, parent)
            w.string(prefix + name)
            w.align(8)
            poses.append(self._f64_at(len(w.buf), 7))
            w.f64s((0.0,) * 7)
        super().__init__(w, stamps)
        self._pose_at = np.array(poses)
        # What ros/steady_lane.py writes a message into, in compiled code: the u32 view, the
        # stamps' indices, the f64 view, the poses' indices; the message is then ``u8``'s bytes.
        self.layout = (self._u32, self._stamp_at, self._f64, self._pose_at)
        self.u8 = self._u8

    def encode(self, poses: np.ndarray, stamp_ns: int) -> bytes:
        """Return the message's bytes with these stamps and poses.

        :param poses: (bones, 7) translations (m) then quaternions (x, y, z, w), each bone in
            its parent's frame.
        :param stamp_ns: every transform's stamp, ns.
        """
        put_rows(self._f64, self._pose_at, poses)
        return self._bytes(stamp_ns)


# Compiled scatters: numpy's fancy-index assignments cost a few us each per message, several
# times that when the node wakes to each input with cold caches (/tf at 120 Hz).
# Public: ros/steady_lane.py lays its /tf out with them.
@njit(cache=True)
def put_stamp(u32, stamp_at, stamp_ns):
    """Write a stamp as its seconds (int32 bits) and nanoseconds at each of ``stamp_at``."""
    sec = (stamp_ns // 1_000_000_000) & 0xFFFFFFFF
    nanosec = stamp_ns % 1_000_000_000
    for i in range(stamp_at.shape[0]):
        u32[stamp_at[i, 0]] = sec
        u32[stamp_at[i, 1]] = nanosec


@njit(cache=True)
def put_rows(f64, at, rows):
    """Write ``rows[i, k]`` at ``f64[at[i, k]]``."""
    for i in range(at.shape[0]):
        for k in range(at.shape[1]):
            f64[at[i, k]] = rows[i, k]


def marker(w: CdrWriter, m: 'MarkerSpec', stamp_ns: int,
           frame: str) -> tuple[int, int, int, int]:
    """One visualization_msgs/Marker from a :class:`messages.MarkerSpec`.

    :param w: the writer the marker is appended to.
    :param m: the marker.
    :param stamp_ns: its header stamp, ns.
    :param frame: its header frame.
    :returns: where its varying fields start: (stamp, pose, points, colors) byte offsets; the
        scale's three doubles follow the pose's seven.
    """
    w.align(4)
    stamp_at = len(w.buf)
    w.header(stamp_ns, frame)
    w.string(m.ns)
    w.i32(m.id)
    w.i32(m.type)
    w.i32(m.action)
    w.align(8)
    pose_at = len(w.buf)
    w.f64s(tuple(m.position) + tuple(m.orientation) + tuple(m.scale))
    w.f32s(tuple(m.color))
    w.i32(m.lifetime_s)
    w.u32(0)
    w.u8(0)                                  # frame_locked
    points = np.zeros((0, 3)) if m.points is None else m.points
    w.u32(len(points))
    w.align(8)
    points_at = len(w.buf)
    if len(points):
        w.f64_array(points)
    colors = np.zeros((0, 4)) if m.colors is None else np.asarray(m.colors)
    w.u32(len(colors))                       # one per point: a mesh's shading
    w.align(4)
    colors_at = len(w.buf)
    if len(colors):
        w.buf += np.ascontiguousarray(colors, dtype='<f4').tobytes()
    w.string('')                             # texture_resource
    w.header(0, '')                          # texture: CompressedImage header, format, data
    w.string('')
    w.u32(0)
    w.u32(0)                                 # uv_coordinates
    w.string('')                             # text
    w.string('')                             # mesh_resource
    w.string('')                             # mesh_file.filename
    w.u32(0)                                 # mesh_file.data
    w.u8(0)                                  # mesh_use_embedded_materials
    return stamp_at, pose_at, points_at, colors_at


def marker_array(markers: 'Sequence[MarkerSpec]', stamp_ns: int, frame: str) -> bytes:
    """visualization_msgs/MarkerArray, field by field (see MarkerTemplate).

    :param markers: the markers with their values.
    :param stamp_ns: every marker's stamp, ns.
    :param frame: every marker's frame.
    """
    w = CdrWriter()
    w.u32(len(markers))
    for m in markers:
        marker(w, m, stamp_ns, frame)
    return w.bytes()


class MarkerTemplate(_Template):
    """The bytes of a MarkerArray of one layout (messages.marker_layout), laid out once.

    Each message writes its stamps, the poses and scales of the markers with a ``pose_row``
    and the points of those with ``point_rows`` into place instead of encoding field by field
    (mostly small appends, costly in Python). The bytes equal
    :func:`marker_array`'s of the same markers.

    :param layout: the markers, their varying values aside.
    :param frame: every marker's frame.
    :param pose_rows: the rows of the pose table fill makes.
    """

    def __init__(self, layout: 'Sequence[MarkerSpec]', frame: str, pose_rows: int):
        w = CdrWriter()
        w.u32(len(layout))
        stamps, dst, src = [], [], []
        self.meshes = {}                              # name -> (points, colors) views, filled
        width = 10                                   # pose (7) and scale (3) doubles
        meshes = []
        for m in layout:
            rows = m.point_rows
            if rows is not None:
                m = dataclasses.replace(m, points=np.zeros((len(rows), 3)))
            if m.mesh:
                m = dataclasses.replace(m, points=np.zeros((m.mesh_points, 3)),
                                        colors=np.zeros((m.mesh_points, 4)))
            stamp_at, pose_at, points_at, colors_at = marker(w, m, 0, frame)
            if m.mesh:
                meshes.append((m.mesh, points_at, colors_at, m.mesh_points))
            stamps.append(stamp_at)
            if m.pose_row >= 0:
                dst.append(self._f64_at(pose_at, width))
                src.append(m.pose_row * width + np.arange(width))
            if rows is not None:
                dst.append(self._f64_at(points_at, 3 * len(rows)))
                src.append(pose_rows * width + (3 * np.asarray(rows)[:, None]
                                                + np.arange(3)).reshape(-1))
        super().__init__(w, stamps)
        # Without the debug layer nothing comes from the tables.
        self._dst = np.concatenate(dst) if dst else np.zeros(0, dtype=np.int64)
        self._src = np.concatenate(src) if src else np.zeros(0, dtype=np.int64)
        f32 = self._u8[4:4 + (len(self._u8) - 4) // 4 * 4].view('<f4')
        for name, points_at, colors_at, n in meshes:
            at, c_at = (points_at - 4) // 8, (colors_at - 4) // 4
            self.meshes[name] = (self._f64[at:at + 3 * n].reshape(n, 3),
                                 f32[c_at:c_at + 4 * n].reshape(n, 4))

    def encode(self, fill: Callable[..., None], arguments: tuple, stamp_ns: int) -> bytes:
        """Return the message's bytes with the values ``fill(*arguments, src, dst, doubles)``.

        A mesh marker's points and colours are written into :attr:`meshes` before this.

        :param fill: makes the pose and point tables (as messages.marker_values) and scatters
            ``doubles[dst] = tables[src]`` (marker_kernel.fill_markers).
        :param arguments: fill's arguments before the template's own.
        :param stamp_ns: every marker's stamp, ns.
        """
        if len(self._src):
            fill(*arguments, self._src, self._dst, self._f64)
        return self._bytes(stamp_ns)


def diagnostic_array(stamp_ns: int, statuses: Sequence[tuple]) -> bytes:
    """diagnostic_msgs/DiagnosticArray from (level, name, message, hardware_id, {key: value}).

    :param stamp_ns: the array's stamp, ns.
    :param statuses: (level, name, message, hardware_id, {key: value}) each.
    """
    w = CdrWriter()
    w.header(stamp_ns, '')
    w.u32(len(statuses))
    for level, name, message, hardware_id, values in statuses:
        w.u8(level)
        w.string(name)
        w.string(message)
        w.string(hardware_id)
        w.u32(len(values))
        for k, v in values.items():
            w.string(str(k))
            w.string(str(v))
    return w.bytes()


# What bad JointState bytes raise in JointStateReader.read.
DECODE_ERRORS = (ValueError, struct.error, UnicodeDecodeError)


class Undecodable(ValueError):
    """JointState bytes that do not decode: any of DECODE_ERRORS, raised as one."""


class JointStateContent:
    """What the simulation reads of a sensor_msgs/JointState: stamp, names, positions.

    :param stamp_ns: the header stamp, ns.
    :param name: the joint names.
    :param position: one value per name (rad or m).
    """

    __slots__ = ('stamp_ns', 'name', 'position')

    def __init__(self, stamp_ns: int, name: tuple[str, ...], position: np.ndarray):
        self.stamp_ns, self.name, self.position = stamp_ns, name, position


class JointStateReader:
    """Decodes the stamp, names and positions of CDR JointState bytes, skipping the rest.

    Why not rclpy's deserialize_message: it builds the whole message object, velocities and
    efforts included, a visible share of an input. A publisher sends the same name list
    every time, so the names are decoded once and then recognised by their bytes; a list in
    other padding (rclpy's serializer leaves it as its buffer held it) is decoded again and
    kept if its names are the same, and ``name_code`` lets the steady lane pass over the
    padding. Big-endian bytes go through rclpy; malformed bytes raise ValueError, struct.error
    or UnicodeDecodeError (DECODE_ERRORS; callers name the message).
    """

    def __init__(self):
        # The name list last decoded and its bytes as the last message held them; their code
        # is public for ros/steady_lane.py, which recognises the list in compiled code.
        self._names_bytes = b''
        self.names = ()
        self.name_code = _name_code(b'')

    def read(self, raw: bytes) -> JointStateContent:
        """Return the stamp, names and positions of a JointState's CDR bytes; ValueError if bad.

        :param raw: the serialized message.
        """
        raw = bytes(raw)
        if raw[:2] == b'\x00\x00':                 # CDR_BE: not what ROS 2 writes on x86/ARM
            return _joint_state_by_rclpy(raw)
        if len(raw) < 16 or raw[:2] != _HEADER[:2]:
            raise ValueError('not a CDR message')
        sec, nanosec, frame_len = struct.unpack_from('<iII', raw, 4)
        at = _aligned(16 + frame_len, 4)
        if self._names_bytes and raw.startswith(self._names_bytes, at):
            names, at = self.names, at + len(self._names_bytes)
        else:
            start = at
            names, at = _strings(raw, at)
            self._names_bytes = raw[start:at]
            if names != self.names or not len(self.name_code):   # not just other padding
                self.names, self.name_code = names, _name_code(self._names_bytes)
        at = _aligned(at, 4)
        (count,) = struct.unpack_from('<I', raw, at)
        at = _aligned(at + 4, 8)
        if at + 8 * count > len(raw):
            raise ValueError('positions run past the end of the message')
        position = np.frombuffer(raw, dtype='<f8', count=count, offset=at)
        return JointStateContent(sec * 1_000_000_000 + nanosec, names, position)


def deserialize(raw: bytes, msg_type: type) -> object:
    """Deserialize as rclpy does, failing with ValueError on bytes that are no ``msg_type``.

    :param raw: the serialized message.
    :param msg_type: the message class expected.
    """
    from rclpy.serialization import deserialize_message

    from .cdr_bounds import check_whole
    raw = bytes(raw)
    check_whole(raw, msg_type)      # Fast CDR would read past the end of short bytes
    try:
        return deserialize_message(raw, msg_type)
    except Exception as e:  # noqa: BLE001 - rclpy raises its own error types
        raise ValueError(str(e)) from None


def _joint_state_by_rclpy(raw):
    from sensor_msgs.msg import JointState
    msg = deserialize(raw, JointState)
    return JointStateContent(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec,
                             tuple(msg.name), np.array(msg.position, dtype=float))


def _aligned(at, n):
    return at + (-(at - 4) % n)


def _name_code(names_bytes):
    """Return a sequence<string>'s bytes as read-only int16, -1 on the padding between them.

    -1 matches any byte (steady_lane.read_steady): serializers need not zero padding.
    """
    code = np.frombuffer(names_bytes, dtype=np.uint8).astype(np.int16)
    at = 4                                  # the count; each string starts 4-aligned
    while at < len(code):
        (n,) = struct.unpack_from('<I', names_bytes, at)
        at += 4 + n
        pad = -at % 4
        code[at:at + pad] = -1
        at += pad
    code.flags.writeable = False
    return code


def _strings(raw, at):
    """Read a CDR sequence<string> at ``at``: (tuple of str, offset after it)."""
    (count,) = struct.unpack_from('<I', raw, at)
    at += 4
    if count > len(raw):
        raise ValueError('string count past the end of the message')
    out = []
    for _ in range(count):
        at = _aligned(at, 4)
        (n,) = struct.unpack_from('<I', raw, at)
        if n < 1 or at + 4 + n > len(raw):
            raise ValueError('string runs past the end of the message')
        out.append(raw[at + 4:at + 3 + n].decode())
        at += 4 + n
    return tuple(out), at


@dataclasses.dataclass
class ReadMarker:
    """What a picture reads of one recorded visualization_msgs/Marker."""

    ns: str
    id: int
    type: int
    action: int
    points: np.ndarray      # (P,3) float64
    colors: np.ndarray      # (C,4) float32


def read_markers(raw: bytes) -> list[ReadMarker]:
    """Read a MarkerArray's markers, their points and colours as arrays over the bytes.

    rclpy's ``deserialize_message`` makes a Python object per point and colour: a jacket's
    markers message took tens of milliseconds, most of a session's animation. Laid out by the
    message's rosidl type, so the fields before and after the arrays are walked as rclpy's.

    :param raw: the MarkerArray's CDR bytes.
    :raises ValueError: the bytes are not a whole MarkerArray.
    """
    from visualization_msgs.msg import Marker
    from .cdr_bounds import _Walker
    if len(raw) < 4 or raw[0] != 0 or raw[1] not in (0, 1):
        raise ValueError('not a CDR message')
    endian = '<' if raw[1] == 1 else '>'
    w, i32 = _Walker(raw, endian), struct.Struct(endian + 'i')
    out = []
    for _ in range(w.count()):
        got = {}
        for name, slot in zip(Marker.__slots__, Marker.SLOT_TYPES):
            if name == '_ns':
                n = w.count()
                w.take(n, 1)
                got['ns'] = raw[w.at - n:w.at - 1].decode('utf-8', 'replace')
            elif name in ('_id', '_type', '_action'):
                w.take(4, 4)
                (got[name[1:]],) = i32.unpack_from(raw, w.at - 4)
            elif name in ('_points', '_colors'):
                n = w.count()
                kind, width = ('f8', 3) if name == '_points' else ('f4', 4)
                size = int(kind[1])
                w.take(n * width * size, size)
                got[name[1:]] = np.frombuffer(raw, endian + kind, n * width,
                                              w.at - n * width * size).reshape(n, width)
            else:
                w.field(slot)
        out.append(ReadMarker(**got))
    return out
