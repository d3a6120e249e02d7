# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A DeepMimic motion clip as JointState content for pybullet's DeepMimic humanoid (no ROS).

The clips (``humanoid3d_*.txt`` in pybullet's ``pybullet_data/data/motions``) are JSON:
``{"Loop": ..., "Frames": [[duration, ...], ...]}``. Each frame is 44 numbers, laid out as
pybullet's own reader takes them apart (``pybullet_envs/deep_mimic/env/
humanoid_pose_interpolator.py``, ``Slerp``): the frame's duration (s to the next frame), the
root position (3), then quaternions written w, x, y, z for the root orientation and each
``spherical`` joint and single angles for the ``revolute`` ones, in ``LAYOUT``'s order (the
order ``humanoid_stable_pd.py`` hands them to ``resetJointStatesMultiDof``).

Conventions of the result:

- Axes: the clip's world and the humanoid are both Y-up (x forward, z to the right); the
  world is turned once into REP 103's (x forward, y left, z up: a quarter turn about x,
  ``Y_UP_WORLD``), so the humanoid stands up in a Z-up world through its world joint and the
  URDF is not edited (issue 47 item 1: gravity is the world's, never the body's). The root pose
  is the URDF root link's (``base``: pybullet places a base by its inertial frame, which is at
  this link's origin) and travels on ``world_joint`` as BVH import's does.
- Units: pybullet loads the humanoid at ``globalScaling=0.25`` (``humanoid_stable_pd.py``);
  the URDF as written is four times that, so root positions are multiplied by ``scale`` (URDF
  lengths per clip length, default ``PYBULLET_SCALING``). Angles do not scale.
- Joints: a spherical joint's quaternion q becomes the three continuous joints about z, x and
  y that ``core.skeleton`` chains for it (``BALL_AXES``): R(q) = Rz(a) Rx(b) Ry(c), about the
  joint frame, which is parallel to the parent link's in this URDF (every joint origin has
  rpy 0). Knees and elbows are the file's angle about their z axis.
- Continuity: a, b, c of every frame are taken on the branch (of the two, (a, b, c) and
  (a + pi, pi - b, c + pi)) and whole turns nearest the previous frame's, so the node's linear
  interpolation never swings a joint the long way round, also near b = +-pi/2 (a shoulder
  raised sideways, where a and c alone turn fast).
- Rate: one sample per ``frame_time``, the clip's usual frame duration; a clip whose frames
  are not all that long is resampled at it (slerp for rotations, linear for the rest).
"""

from __future__ import annotations

import json
import math
import os

import numpy as np

from ..core.transforms import quat_slerp, quat_to_matrix
from .bvh import (FRAME_TIME_RANGE, Capture, continuous_angles, continuous_quaternions,
                  not_finite)

# Each joint of pybullet's humanoid.urdf that a frame moves, in the frame's order, and its
# count of numbers: 4 for a spherical joint's quaternion, 1 for a revolute joint's angle.
LAYOUT = (('chest', 4), ('neck', 4), ('right_hip', 4), ('right_knee', 1), ('right_ankle', 4),
          ('right_shoulder', 4), ('right_elbow', 1), ('left_hip', 4), ('left_knee', 1),
          ('left_ankle', 4), ('left_shoulder', 4), ('left_elbow', 1))
FRAME_LENGTH = 1 + 3 + 4 + sum(n for _, n in LAYOUT)
# The humanoid's scale in pybullet's DeepMimic environment, which the clips were made for.
PYBULLET_SCALING = 0.25
_BALL = ('Z', 'X', 'Y')
# The clip's Y-up world in REP 103's Z-up one: a quarter turn about x, (x, y, z) -> (x, -z, y),
# as a matrix and as a quaternion (x, y, z, w).
Y_UP_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
Y_UP_WORLD_QUAT = np.array([math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)])


class ClipError(ValueError):
    """A DeepMimic clip that cannot be imported; the message is one line naming the file."""


def joint_names() -> list:
    """Return the URDF joints a clip moves, in its columns' order (three per ball joint)."""
    names = []
    for joint, n in LAYOUT:
        names += [f'{joint}_{a}rotation' for a in _BALL] if n == 4 else [joint]
    return names


def read_frames(path: str) -> np.ndarray:
    """Return a clip's frames (F, 44); every failure is one ClipError line naming the file.

    :param path: the clip's JSON file.
    """
    if not os.path.isfile(path):
        raise ClipError(f'{path}: no such file')
    try:
        with open(path, encoding='utf-8') as f:
            data = json.load(f)
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ClipError(f'{path}: not a DeepMimic clip (not JSON: {e})') from None
    except RecursionError:
        # The parser recurses once a bracket: arrays nested deeper than the interpreter's
        # stack are no clip, and the error must not surface as a traceback.
        raise ClipError(f'{path}: not a DeepMimic clip (its JSON nests too deep)') from None
    except ValueError as e:     # an integer longer than Python converts from text
        # Its advice, to raise the interpreter's limit, is no help to whoever runs the tool.
        raise ClipError(f'{path}: not a DeepMimic clip ({str(e).split(";")[0]})') from None
    frames = data.get('Frames') if isinstance(data, dict) else None
    if not isinstance(frames, list) or not frames:
        raise ClipError(f'{path}: not a DeepMimic clip (no "Frames" list)')
    for k, frame in enumerate(frames):
        if not isinstance(frame, list) or len(frame) != FRAME_LENGTH or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in frame):
            raise ClipError(f'{path}: frame {k} is not {FRAME_LENGTH} numbers (duration, root '
                            'position and quaternion, 12 joints)')
    try:
        out = np.array(frames, dtype=float)
    except OverflowError:
        # A JSON integer has no bound, a float has: name the frame holding the first too big.
        k = next(k for k, frame in enumerate(frames) if not _floats(frame))
        raise ClipError(f'{path}: frame {k} holds an integer too large for a number') from None
    if not np.isfinite(out).all():
        k = int(np.argmax(~np.isfinite(out).all(axis=1)))
        raise ClipError(f'{path}: frame {k} holds a value that is not a finite number')
    return out


def _floats(frame: list) -> bool:
    """Return whether every value of ``frame`` converts to a float."""
    try:
        [float(v) for v in frame]
    except OverflowError:
        return False
    return True


def _joint_columns() -> list:
    """Return (first column, joint, values) of each joint in a frame, in LAYOUT's order."""
    out, i = [], 8
    for joint, n in LAYOUT:
        out.append((i, joint, n))
        i += n
    return out


def _quaternion_columns() -> list:
    """Return (first column, what) of each quaternion in a frame: the root's, then joints'."""
    return [(4, 'the root orientation')] + [(i, f'joint {joint}')
                                            for i, joint, n in _joint_columns() if n == 4]


def check_quaternions(frames: np.ndarray) -> None:
    """Refuse a frame whose quaternion cannot be normalised, naming the frame and the joint.

    :param frames: the clip's frames, (F, 44), finite.
    """
    for i, what in _quaternion_columns():
        q = frames[:, i:i + 4]
        # Squared, a value this large overflows: its length is no finite number, and the
        # normalised quaternion would be NaN.
        with np.errstate(over='ignore'):
            norm = np.sqrt(np.sum(q * q, axis=1))
        bad = ~(np.isfinite(norm) & (norm >= 1e-6))
        if bad.any():
            k = int(np.argmax(bad))
            reason = 'zero' if norm[k] < 1e-6 else \
                'too long to normalise, its length not a finite number'
            raise ClipError(f'frame {k}: a quaternion is {reason} ({what})')


MAX_RESAMPLED = 100_000         # frames of a resampled clip: DeepMimic clips last seconds


def frame_time(durations: np.ndarray) -> float:
    """Return the clip's frame duration: the most common of its frames' (the last may be 0).

    :param durations: each frame's duration, seconds (the clip's first column).
    """
    steps = durations[:-1] if len(durations) > 1 else durations
    values, counts = np.unique(np.round(steps, 9), return_counts=True)
    return float(values[np.argmax(counts)])


def zxy_angles(r: np.ndarray) -> np.ndarray:
    """Return (..., 3) angles a, b, c with R = Rz(a) Rx(b) Ry(c), b in [-pi/2, pi/2].

    :param r: (..., 3, 3) rotations.
    """
    cb = np.hypot(r[..., 0, 1], r[..., 1, 1])
    b = np.arctan2(r[..., 2, 1], cb)
    a = np.arctan2(-r[..., 0, 1], r[..., 1, 1])
    c = np.arctan2(-r[..., 2, 0], r[..., 2, 2])
    # At b = +-pi/2 only a + c (or a - c) is defined: c = 0 takes it all into a.
    lock = cb < 1e-12
    a = np.where(lock, np.arctan2(r[..., 1, 0], r[..., 0, 0]), a)
    c = np.where(lock, 0.0, c)
    return np.stack([a, b, c], axis=-1)


def continuous_zxy(angles: np.ndarray) -> np.ndarray:
    """Return (F, 3) angles of the same rotations, each frame nearest the frame before.

    :param angles: (F, 3) z, x, y angles per frame, radians.
    """
    out = np.array(angles, dtype=float)
    for k in range(1, len(out)):
        a, b, c = out[k]
        if abs(abs(b) - math.pi / 2) < 1e-9:
            # Locked: Rz(a) Rx(+-pi/2) Ry(c) depends on a +- c only; keep c where it was.
            c = out[k - 1, 2]
            a -= c if b > 0 else -c
        best = None
        for cand in ((a, b, c), (a + math.pi, math.pi - b, c + math.pi)):
            cand = np.asarray(cand)
            cand = cand - 2 * math.pi * np.round((cand - out[k - 1]) / (2 * math.pi))
            if best is None or np.abs(cand - out[k - 1]).max() < np.abs(best - out[k - 1]).max():
                best = cand
        out[k] = best
    return out


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    q = np.roll(wxyz, -1, axis=-1)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if (norm < 1e-6).any():
        raise ClipError('a quaternion is zero')
    return q / norm


def _resample(frames: np.ndarray, dt: float) -> np.ndarray:
    """Return frames at every multiple of ``dt`` over the clip (slerp for quaternions).

    The last one is the clip's last frame, even where the clip's length is no whole number of
    ``dt``: ending short of it dropped the last pose. The whole number nearest the length
    is kept, so the last frame's time is off by half a ``dt`` at most.
    """
    times = np.concatenate([[0.0], np.cumsum(frames[:-1, 0])])
    count = max(int(round(times[-1] / dt)), 1) + 1
    out = np.empty((count, frames.shape[1]))
    quats = [i for i, _ in _quaternion_columns()]
    for j in range(count):
        t = j * dt if j < count - 1 else times[-1]
        k = min(int(np.searchsorted(times, t, side='right')) - 1, len(frames) - 2)
        w = (t - times[k]) / max(times[k + 1] - times[k], 1e-12)
        out[j] = frames[k] + w * (frames[k + 1] - frames[k])
        for i in quats:
            q = quat_slerp(_xyzw(frames[k, i:i + 4]), _xyzw(frames[k + 1, i:i + 4]), w)
            out[j, i:i + 4] = np.roll(q, 1)
    out[:, 0] = dt
    return out


def _turned_quaternions(q: np.ndarray) -> np.ndarray:
    """Return (F, 4) quaternions (x, y, z, w) turned by Y_UP_WORLD: Y_UP_WORLD_QUAT * q."""
    ax, ay, az, aw = Y_UP_WORLD_QUAT
    bx, by, bz, bw = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.column_stack([aw * bx + ax * bw + ay * bz - az * by,
                            aw * by - ax * bz + ay * bw + az * bx,
                            aw * bz + ax * by - ay * bx + az * bw,
                            aw * bw - ax * bx - ay * by - az * bz])


def convert(frames: np.ndarray, name: str, urdf: str, scale: float = 1.0 / PYBULLET_SCALING
            ) -> Capture:
    """Convert a clip's frames (F, 44) into JointState content for ``urdf`` (its text).

    :param frames: the clip's frames, (F, 44).
    :param name: the capture's name.
    :param urdf: the humanoid's URDF text.
    :param scale: metres per clip length unit.
    """
    if not (scale > 0 and math.isfinite(scale)):
        raise ClipError(f'scale must be a positive number, not {scale}')
    if (frames[:, 0] < 0).any():
        raise ClipError(f'frame {int(np.argmax(frames[:, 0] < 0))} lasts less than 0 s')
    dt = frame_time(frames[:, 0])
    if not dt > 0:
        raise ClipError('its frames last 0 s')
    low, high = FRAME_TIME_RANGE
    if not low <= dt <= high:
        raise ClipError(f'its frames last {dt:g} s, outside [{low:g}, {high:g}] s')
    check_quaternions(frames)
    resampled = len(frames) > 1 and np.abs(frames[:-1, 0] - dt).max() > 1e-9
    # A value that overflows is refused below by name; numpy's warnings would only add lines.
    with np.errstate(over='ignore', invalid='ignore'):
        if resampled:
            # Resampled at its usual frame time: as many frames as the clip's length needs, at
            # most MAX_RESAMPLED (a few long frames among short ones could ask for millions).
            count = float(np.sum(frames[:-1, 0])) / dt
            if count > MAX_RESAMPLED:
                raise ClipError(f'its frames, resampled every {dt:g} s, would be {count:.0f}, '
                                f'over {MAX_RESAMPLED}')
            frames = _resample(frames, dt)
        columns = []
        for i, _, n in _joint_columns():
            if n == 4:
                rot = quat_to_matrix(_xyzw(frames[:, i:i + 4]))
                columns.append(continuous_zxy(zxy_angles(rot)))
            else:
                columns.append(continuous_angles(frames[:, i:i + 1]))
        root_q = continuous_quaternions(_turned_quaternions(_xyzw(frames[:, 4:8])))
        root_p = frames[:, 1:4] @ Y_UP_WORLD.T * scale
    capture = Capture(name=name, urdf=urdf, frame_time=dt, scale=scale,
                      joint_names=joint_names(), positions=np.hstack(columns),
                      root=np.hstack([root_p, root_q]), link_names=[], height_m=float('nan'))
    problem = not_finite(capture)
    if problem:
        raise ClipError(f'{problem} (root positions times {scale:g}'
                        + (f', frames resampled every {dt:g} s)' if resampled else ')'))
    return capture


def load_clip(path: str, urdf_path: str, scale: float | None = None) -> Capture:
    """Read the clip ``path`` and convert it for the humanoid ``urdf_path`` (checked to fit).

    :param path: the clip's JSON file.
    :param urdf_path: the humanoid's URDF file.
    :param scale: metres per clip length unit; None: the default, 1 / PYBULLET_SCALING.
    """
    from ..core.config import read_text
    from ..core.skeleton import skeleton_from
    frames = read_frames(path)
    text = read_text(urdf_path, 'URDF')
    skeleton = skeleton_from(text, f'URDF {urdf_path}')
    missing = [j for j in joint_names() if j not in skeleton.joint_index]
    if missing:
        raise ClipError(f'{urdf_path} has no joint {missing[0]!r}: a DeepMimic clip moves '
                        "pybullet's humanoid.urdf (chest, neck, hips, knees, ankles, shoulders, "
                        'elbows)')
    name = os.path.splitext(os.path.basename(path))[0] or 'clip'
    try:
        return convert(frames, name, text, 1.0 / PYBULLET_SCALING if scale is None else scale)
    except ClipError as e:
        raise ClipError(f'{path}: {e}') from None
