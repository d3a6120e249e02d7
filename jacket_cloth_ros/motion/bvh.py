# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A BVH motion capture as what the node consumes: a URDF and JointState content (no ROS).

The file is read with pybvh (a maintained reader: numpy float64 throughout, angles in
radians, each joint's Euler order as its CHANNELS line gives it). Conventions of the result:

- Axes: BVH is Y-up and a character at rest faces +Z with its left on +X. The URDF and the
  world are Z-up with the character facing +X and its left on +Y (REP 103), so every vector
  is turned once by ``Y_UP_TO_Z_UP``: x = z_bvh, y = x_bvh, z = y_bvh. Every link frame is
  parallel to the world at the rest pose (all channels zero), so a rig written for Z-up link
  frames fits.
- Units: BVH lengths times ``scale`` are metres; without one, ``guess_scale`` picks metres,
  centimetres, millimetres or inches from the rest skeleton's height.
- Joints: a BVH joint with rotation channels becomes one revolute joint per channel, named
  ``<joint>_<channel>`` (``Chest_Zrotation``), chained through massless links
  ``<joint>_<channel>_link`` in the order of its CHANNELS line. That order is the capture's
  own Euler order (R = R1 R2 R3, intrinsic), so the values are the file's, in radians, with
  no conversion that could meet gimbal lock. They are ``continuous`` (no limits). An End
  Site becomes a fixed link ``<joint>_end``.
- Root: the BVH root is the URDF's root link; its position and rotation channels travel as
  the MoveIt floating joint ``world_joint`` (``trans_x`` ... ``rot_w``), not in the URDF. As
  pybvh (and most readers) does, the root's position channels place it and its OFFSET is
  not added.
- Continuity: the node interpolates joint values linearly between samples, so every angle
  channel is unwrapped over time (whole turns added or taken away) until consecutive samples
  never differ by more than pi; otherwise the values are the file's. The root quaternion
  keeps one sign (q and -q are one rotation).
"""

from __future__ import annotations

import dataclasses
import math
import os
import tempfile
import warnings
import xml.etree.ElementTree as ElementTree
from typing import TYPE_CHECKING

import numpy as np

from ..core.config import MAX_COORDINATE, ConfigError
from ..core.skeleton import MAX_LINKS, Skeleton
from ..core.transforms import matrix_to_quat

if TYPE_CHECKING:           # for the annotations only: pybvh is imported when a file is read
    from pybvh import Bvh

# Rows give the Z-up coordinates of a BVH vector: x = z_bvh, y = x_bvh, z = y_bvh.
Y_UP_TO_Z_UP = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
_AXIS = {'X': 0, 'Y': 1, 'Z': 2}
# Candidate units of a capture (metres per BVH unit), for guess_scale. CMU's captures as
# converted for 3ds Max (cgspeed's, the most shared) are in inches divided by 0.45.
UNITS = {'m': 1.0, 'cm': 0.01, 'mm': 0.001, 'in': 0.0254, 'CMU (in / 0.45)': 0.0254 / 0.45}
# The height a guessed unit aims for: an adult's, in metres.
_TYPICAL_HEIGHT_M = 1.7
# Heights of people outside which a capture's unit is likely wrong, in metres.
HUMAN_HEIGHT_M = (1.2, 2.2)


# A channel's angle beyond this (degrees) is a corrupted value, not turns a capture unwrapped:
# its spike would pose the frame at random.
MAX_ANGLE_DEG = 1e6
# The farthest a capture's root may be from its origin, m: a capture volume is tens of
# metres; beyond this a frame is corrupted, and 1e300 m gave figures of 280 digits.
MAX_ROOT_M = 1e6

# Seconds between frames: 10 kHz to 1 Hz. Shorter made stamps repeat (whole ns); longer put
# a capture's stamps beyond what a header stamp holds.
FRAME_TIME_RANGE = (1e-4, 1.0)


class BvhError(ValueError):
    """A BVH file that cannot be imported; the message is one line naming the file."""


@dataclasses.dataclass
class Capture:
    """A BVH capture converted: the URDF, and per frame its joint values and root pose."""

    name: str                    # the robot's name (the file's stem)
    urdf: str                    # URDF text: links and joints of the skeleton, Z-up, metres
    frame_time: float            # seconds between frames (the reader's, see frame_time)
    scale: float                 # metres per BVH unit
    joint_names: list            # the URDF's revolute joints, in the columns' order
    positions: np.ndarray        # (F, J) joint values, radians, continuous over time
    root: np.ndarray             # (F, 7) root pose: x, y, z (m), qx, qy, qz, qw
    link_names: list             # the BVH joints' and end sites' links, file order
    height_m: float              # the rest skeleton's height, metres
    # Its rest skeleton's extents along the file's x, y and z, metres (y: its height).
    spans_m: tuple = (float('nan'),) * 3
    # (name in the file, name taken) of each joint whose name had spaces, joined by '_'.
    renamed: tuple = ()

    @property
    def frames(self) -> int:
        """Return the number of frames."""
        return len(self.positions)


# What each column of a capture's root pose is, as a refusal names it.
_ROOT_PARTS = ('x position', 'y position', 'z position', 'orientation qx', 'orientation qy',
               'orientation qz', 'orientation qw')


def not_finite(capture: Capture) -> str | None:
    """Return a phrase naming the first frame and value that is no usable number, or None.

    The check every importer makes after scaling and normalising, before anything is
    written: a NaN or an infinity in a JointState is no pose the node can take, nor a root
    beyond MAX_ROOT_M from the origin.

    :param capture: an imported capture (its ``positions`` and ``root``).
    """
    values = np.hstack([capture.positions, capture.root])
    bad = ~np.isfinite(values)
    if bad.any():
        k, j = (int(v) for v in np.argwhere(bad)[0])
        joints = len(capture.joint_names)
        what = f'joint {capture.joint_names[j]}' if j < joints else \
            f"the root's {_ROOT_PARTS[j - joints]}"
        return (f'frame {k}: {what} is {values[k, j]} after scaling and normalising, not a '
                'finite number')
    far = np.abs(capture.root[:, :3]).max(axis=1) if len(capture.root) else np.zeros(1)
    if far.max() <= MAX_ROOT_M:
        return None
    k = int(np.argmax(far))
    return (f'frame {k}: the root is {far[k]:.3g} m from the origin, beyond the '
            f'{MAX_ROOT_M:g} m a capture\'s root may reach (a corrupted frame?)')


def read_bvh(path: str) -> tuple[Bvh, tuple]:
    """Read ``path`` with pybvh; every failure becomes one BvhError line naming the file.

    A joint name with spaces (``JOINT Left Hip``), which the reader cuts at the first, is
    read with its words joined by '_' (``Left_Hip``).

    :param path: the BVH file.
    :returns: (the capture read, (name in the file, name taken) of each name joined).
    """
    if not os.path.isfile(path):
        raise BvhError(f'{path}: no such file')
    if os.path.getsize(path) == 0:
        raise BvhError(f'{path}: empty file')
    counts, spaced = _hierarchy_counts(path)
    if not spaced:
        return _read(path, *counts), ()
    with tempfile.TemporaryDirectory() as tmp:
        joined = os.path.join(tmp, os.path.basename(path))
        # Byte for byte but the names joined: latin-1 reads and writes every byte as it is.
        with open(path, encoding='latin-1', newline='') as f, \
                open(joined, 'w', encoding='latin-1', newline='') as out:
            for k, line in enumerate(f):
                if k in spaced:
                    words = line.split()
                    line = line[:len(line) - len(line.lstrip())] + words[0] + ' ' + \
                        '_'.join(words[1:]) + line[len(line.rstrip('\r\n')):]
                out.write(line)
        try:
            bvh = _read(joined, *counts)
        except BvhError as e:
            raise BvhError(str(e).replace(joined, path)) from None
    return bvh, tuple(spaced.values())


def _read(path, links, opened, closed, given):
    """Read ``path`` with pybvh once its HIERARCHY was counted (_hierarchy_counts).

    ``given``: the number on its Frame Time line, or None.
    """
    import pybvh
    if links > MAX_LINKS:           # before the reader spends seconds on it
        raise BvhError(f'{path}: its skeleton would be {links} links as a URDF, over the '
                       f'{MAX_LINKS} a character may have')
    if opened != closed:            # the reader guesses where a brace was missing
        raise BvhError(f'{path}: its HIERARCHY opens {opened} braces and closes {closed}')
    low, high = FRAME_TIME_RANGE
    if given is not None and not low <= given <= high:       # NaN too: the reader fails on it
        raise BvhError(f'{path}: Frame Time {given:g} is outside [{low:g}, {high:g}] s')
    try:
        with warnings.catch_warnings():
            # The capture is Y-up by the format's convention: no guessing, so no warning.
            warnings.simplefilter('ignore')
            bvh = pybvh.read_bvh_file(path, world_up='+y')
    except Exception as e:  # noqa: BLE001 - the reader raises many kinds; all mean "bad BVH"
        text = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        text = text.replace(f' in file {path}', '').replace(f' {path}', ' the file')
        raise BvhError(f'{path}: not a readable BVH file ({text})') from None
    if bvh.frame_count < 1:
        raise BvhError(f'{path}: no frames')
    if not low <= bvh.frame_time <= high:       # NaN too
        raise BvhError(f'{path}: Frame Time {bvh.frame_time:g} is outside [{low:g}, {high:g}] s')
    if not (np.isfinite(bvh.root_pos).all() and np.isfinite(bvh.joint_angles).all()):
        raise BvhError(f'{path}: a channel value is not a finite number')
    size = np.abs(bvh.joint_angles)
    if size.size and size.max() > math.radians(MAX_ANGLE_DEG):
        k, j, c = (int(i) for i in np.unravel_index(np.argmax(size), size.shape))
        raise BvhError(f'{path}: frame {k}: {bvh.joint_names[j]} turns '
                       f'{math.degrees(bvh.joint_angles[k, j, c]):.3g} deg, beyond the '
                       f'{MAX_ANGLE_DEG:g} any joint may (a corrupted frame?)')
    for node in bvh.nodes:
        if not np.isfinite(np.asarray(node.offset, dtype=float)).all():
            raise BvhError(f'{path}: the OFFSET of {node.name} is not three finite numbers')
    return bvh


def _hierarchy_counts(path):
    """Read the file's HIERARCHY and MOTION head: (counts for :func:`_read`, names).

    The counts: links as a URDF (the root, one a rotation channel of every other joint, and
    one an End Site), braces opened and closed, and the number on the Frame Time line or None
    (the reader fails on a NaN there, saying only that). A file that is no BVH counts few, and
    the reader says what is wrong with it. Names: {line index: (name, its words joined by
    '_')} of each ROOT or JOINT named with spaces.
    """
    links, channels_seen, opened, closed, spaced, given = 1, 0, 0, 0, {}, None
    try:
        with open(path, encoding='utf-8', errors='replace') as f:
            for k, line in enumerate(f):
                words = line.split()
                if not words:
                    continue
                if words[0] == 'MOTION':
                    given = _frame_time(f)
                    break
                if words[0] in ('ROOT', 'JOINT') and len(words) > 2:
                    spaced[k] = (' '.join(words[1:]), '_'.join(words[1:]))
                # A line of its own each, as the format lays them out: one in a name is none.
                opened += words[0] == '{'
                closed += words[0] == '}'
                if words[0] == 'End':
                    links += 1
                elif words[0] == 'CHANNELS':
                    channels_seen += 1
                    if channels_seen > 1:       # the root's are the world joint's
                        links += sum(w.endswith('rotation') for w in words[2:])
    except OSError:
        return (0, 0, 0, None), {}          # the reader says so
    return (links, opened, closed, given), spaced


def _frame_time(lines):
    """Return the number on the Frame Time line of a MOTION head (its next lines), or None."""
    for _, line in zip(range(2), lines):
        if line.strip().lower().startswith('frame time:'):
            try:
                return float(line.split(':', 1)[1])
            except ValueError:
                return None
    return None


def rest_offsets(bvh: Bvh) -> np.ndarray:
    """Return every node's rest position (N, 3) in BVH units and axes, the root at zero.

    :param bvh: the capture as ``read_bvh`` read it.
    """
    index = {id(n): i for i, n in enumerate(bvh.nodes)}
    out = np.zeros((len(bvh.nodes), 3))
    for i, node in enumerate(bvh.nodes):
        if node.parent is not None:
            out[i] = out[index[id(node.parent)]] + np.asarray(node.offset, dtype=float)
    return out


def height_warning(capture: 'Capture') -> str | None:
    """Return a line if the capture's rest skeleton is no person's (its size, its up), else None.

    :param capture: an imported capture (its ``spans_m``, ``height_m`` and ``scale``).
    """
    low, high = HUMAN_HEIGHT_M
    if _lies_along_z(capture.spans_m):
        # Another unit would not mend it: a z-up export lies along BVH's forward axis.
        return (f'the rest skeleton spans most along z, not y, which BVH stands on and this '
                f'import reads as up (it is {capture.height_m:.2f} m tall along y): export the '
                'capture y-up')
    if low <= max(capture.spans_m) <= high:
        return None
    return (f'the capture is {capture.height_m:.2f} m tall at {capture.scale:g} m per unit, not '
            f'a person\'s {low:g}-{high:g} m: give its unit with --scale')


def _lies_along_z(spans):
    """Tell whether a rest skeleton's spans (x, y, z) say it was exported z-up.

    Twice as far along z as along y: a T-pose's arms span x, which says nothing of its up.
    """
    return bool(spans[2] > 2.0 * spans[1])


def guess_scale(bvh: Bvh) -> tuple[float, str]:
    """Return (metres per unit, unit name) whose rest skeleton is nearest an adult's height.

    :param bvh: the capture as ``read_bvh`` read it.
    """
    # The largest span, not the height along y: a capture of the upper body alone spans a
    # person's height with its arms (a T-pose's span is about the height), and a z-up
    # export spans it along z (which is said).
    height = float(np.ptp(rest_offsets(bvh), axis=0).max())
    if height <= 0.0:
        return 1.0, 'm'
    unit = min(UNITS, key=lambda u: abs(math.log(height * UNITS[u] / _TYPICAL_HEIGHT_M)))
    return UNITS[unit], unit


def axis_rotations(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Return rotations (F, 3, 3) by ``angles`` (F,) about a unit ``axis`` (Rodrigues).

    :param axis: the unit axis, (3,).
    :param angles: one angle a frame, (F,) in rad.
    """
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                  [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def continuous_angles(angles: np.ndarray) -> np.ndarray:
    """Return angles (F, ...) moved by whole turns so consecutive frames differ by at most pi.

    A capture that wraps at +-pi (179 degrees, then -179) would otherwise be interpolated the
    long way round, through a whole turn of the joint between two samples.

    :param angles: the angles, rad, frames along the first axis.
    """
    return np.unwrap(np.asarray(angles, dtype=float), axis=0)


def continuous_quaternions(quat: np.ndarray) -> np.ndarray:
    """Return (F, 4) quaternions with one sign throughout (q and -q are one rotation).

    A flip between frames would read as a jump: interpolation would turn the long way.

    :param quat: one quaternion a frame, (F, 4).
    """
    quat = np.array(quat, dtype=float)
    flips = np.sum(quat[1:] * quat[:-1], axis=1) < 0.0
    quat[1:] *= np.where(np.cumsum(flips) % 2 == 1, -1.0, 1.0)[:, None]
    return quat


def _urdf(bvh, name: str, scale: float) -> tuple[str, list, list]:
    """Return the URDF text, its revolute joints' names and the node links' names."""
    robot = ElementTree.Element('robot', name=name)
    robot.append(ElementTree.Comment(
        f' Made by jacket_cloth import from a BVH capture: Z-up, metres ({scale:g} per BVH '
        'unit), one revolute joint per rotation channel in the file\'s order. '))
    links, joints, node_links = set(), [], []

    def link(link_name):
        if link_name in links:
            raise BvhError(f'two parts of the skeleton are both named {link_name!r}')
        links.add(link_name)
        ElementTree.SubElement(robot, 'link', name=link_name)

    def joint(joint_name, kind, parent, child, xyz=(0.0, 0.0, 0.0), axis=None):
        j = ElementTree.SubElement(robot, 'joint', name=joint_name, type=kind)
        ElementTree.SubElement(j, 'parent', link=parent)
        ElementTree.SubElement(j, 'child', link=child)
        ElementTree.SubElement(j, 'origin', xyz=' '.join(repr(float(v)) for v in xyz),
                               rpy='0 0 0')
        if axis is not None:
            ElementTree.SubElement(j, 'axis', xyz=' '.join(repr(float(v)) for v in axis))

    node_link = {}
    for node in bvh.nodes:
        if node.parent is None:
            link_name = node.name
            link(link_name)
        else:
            parent = node_link[id(node.parent)]
            xyz = Y_UP_TO_Z_UP @ np.asarray(node.offset, dtype=float) * scale
            if node.is_end_site():
                link_name = f'{node.parent.name}_end'
                link(link_name)
                joint(f'{link_name}_fixed', 'fixed', parent, link_name, xyz)
            else:
                link_name = node.name
                for i, ch in enumerate(node.rot_channels):
                    last = i == len(node.rot_channels) - 1
                    child = link_name if last else f'{node.name}_{ch}rotation_link'
                    link(child)
                    joint_name = f'{node.name}_{ch}rotation'
                    joint(joint_name, 'continuous', parent, child, xyz,
                          Y_UP_TO_Z_UP[:, _AXIS[ch]])
                    joints.append(joint_name)
                    parent, xyz = child, (0.0, 0.0, 0.0)
        node_link[id(node)] = link_name
        node_links.append(link_name)
    ElementTree.indent(robot)
    text = '<?xml version="1.0"?>\n' + ElementTree.tostring(robot, encoding='unicode') + '\n'
    return text, joints, node_links


def convert(bvh: Bvh, name: str, scale: float | None = None) -> Capture:
    """Convert a capture read by ``read_bvh`` into the URDF and the JointState content.

    :param bvh: the capture as ``read_bvh`` read it.
    :param name: the robot's name in the URDF.
    :param scale: metres per BVH unit; None: ``guess_scale``'s.
    """
    if scale is None:
        scale, _ = guess_scale(bvh)
    if not (scale > 0 and math.isfinite(scale)):
        raise BvhError(f'scale must be a positive number, not {scale}')
    for node in bvh.nodes[1:]:
        reach = float(np.abs(np.asarray(node.offset, dtype=float)).max()) * scale
        if not reach <= MAX_COORDINATE:
            part = f'the End Site of {node.parent.name}' if node.is_end_site() else node.name
            raise BvhError(f'the OFFSET of {part} reaches {reach:g} m at {scale:g} m per unit, '
                           f'beyond the {MAX_COORDINATE:g} m a skeleton may')
    urdf, joint_names, link_names = _urdf(bvh, name, scale)
    try:            # the limits every tool applies to a URDF, before anything is written
        Skeleton(urdf)
    except ConfigError as e:
        raise BvhError(f'its skeleton as a URDF is refused ({str(e).removeprefix("URDF: ")})'
                       ) from None
    # A value that overflows is refused below by name; numpy's warnings would only add lines.
    with np.errstate(over='ignore', invalid='ignore'):
        angles = continuous_angles(bvh.joint_angles)
        # joint_angles holds the root first, then each joint in file order, as the URDF does.
        positions = angles[:, 1:, :].reshape(len(angles), -1)
        root = bvh.nodes[0]
        rot = np.tile(np.eye(3), (len(angles), 1, 1))
        for i, ch in enumerate(root.rot_channels):
            rot = rot @ axis_rotations(Y_UP_TO_Z_UP[:, _AXIS[ch]], angles[:, 0, i])
        quat = continuous_quaternions(matrix_to_quat(rot))
        trans = bvh.root_pos @ Y_UP_TO_Z_UP.T * scale
    spans = np.ptp(rest_offsets(bvh), axis=0)
    capture = Capture(name=name, urdf=urdf, frame_time=float(bvh.frame_time), scale=scale,
                      joint_names=joint_names, positions=positions,
                      root=np.hstack([trans, quat]), link_names=link_names,
                      height_m=float(spans[1]) * scale,
                      spans_m=tuple(float(v) * scale for v in spans))
    problem = not_finite(capture)
    if problem:
        raise BvhError(f'{problem} (at {scale:g} m per unit)')
    return capture


def load_capture(path: str, scale: float | None = None) -> Capture:
    """Read and convert the BVH file ``path``; the robot is named after the file.

    :param path: the BVH file.
    :param scale: metres per BVH unit; None: ``guess_scale``'s.
    """
    name = os.path.splitext(os.path.basename(path))[0] or 'capture'
    bvh, renamed = read_bvh(path)
    try:
        return dataclasses.replace(convert(bvh, name, scale), renamed=renamed)
    except BvhError as e:
        joined = f' (joint names with spaces, their words joined by _: ' \
            f'{", ".join(repr(b) for _, b in renamed)})' if renamed else ''
        raise BvhError(f'{path}: {e}{joined}') from None


def joint_state_content(capture: Capture, frame: int,
                        world_joint: str = 'world_joint') -> tuple[list, list]:
    """Return (names, positions) of one frame: every joint, then the root's seven variables.

    :param capture: the imported capture.
    :param frame: the frame's index, from 0.
    :param world_joint: the name of the joint carrying the root's world motion.
    """
    from ..core.inputs import WORLD_VARIABLES
    names = list(capture.joint_names) + [f'{world_joint}/{v}' for v in WORLD_VARIABLES]
    return names, [float(v) for v in capture.positions[frame]] + \
        [float(v) for v in capture.root[frame]]


def stamps_ns(capture: Capture, start_ns: int) -> np.ndarray:
    """Return each frame's stamp: ``start_ns`` plus the frame's time at the capture's rate.

    :param capture: the imported capture.
    :param start_ns: the first frame's stamp, ns.
    """
    return start_ns + np.round(np.arange(capture.frames) * capture.frame_time * 1e9).astype(
        np.int64)
