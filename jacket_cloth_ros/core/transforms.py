# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Rigid-transform helpers, vectorised. Quaternions are (x, y, z, w) as in ROS messages."""

import numpy as np
import numpy.typing as npt


def rpy_matrix(rpy: npt.ArrayLike) -> np.ndarray:
    """URDF roll-pitch-yaw (fixed axes x, y, z) to a 3x3 rotation.

    :param rpy: roll, pitch, yaw in radians.
    """
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def quat_to_matrix(q: npt.ArrayLike) -> np.ndarray:
    """(...,4) quaternions (x, y, z, w), normalised here, to (...,3,3) rotations.

    :param q: (..., 4) quaternions (x, y, z, w).
    """
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - z * w)
    r[..., 0, 2] = 2 * (x * z + y * w)
    r[..., 1, 0] = 2 * (x * y + z * w)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - x * w)
    r[..., 2, 0] = 2 * (x * z - y * w)
    r[..., 2, 1] = 2 * (y * z + x * w)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def cross(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Return np.cross of (..., 3) arrays without its axis juggling.

    The juggling costs more than the product at these sizes.

    :param a: (..., 3) vectors.
    :param b: (..., 3) vectors.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def matrix_to_quat(r: npt.ArrayLike) -> np.ndarray:
    """(...,3,3) rotations to unit (...,4) quaternions (x, y, z, w) with w >= 0.

    :param r: (..., 3, 3) rotations.
    """
    r = np.asarray(r, dtype=float)
    m00, m11, m22 = r[..., 0, 0], r[..., 1, 1], r[..., 2, 2]
    # Four candidate magnitudes; take each component's sign from the largest (Shepperd).
    q = np.stack([
        np.sqrt(np.maximum(0.0, 1 + m00 - m11 - m22)),
        np.sqrt(np.maximum(0.0, 1 - m00 + m11 - m22)),
        np.sqrt(np.maximum(0.0, 1 - m00 - m11 + m22)),
        np.sqrt(np.maximum(0.0, 1 + m00 + m11 + m22)),
    ], axis=-1) * 0.5
    q[..., 0] = np.copysign(q[..., 0], r[..., 2, 1] - r[..., 1, 2])
    q[..., 1] = np.copysign(q[..., 1], r[..., 0, 2] - r[..., 2, 0])
    q[..., 2] = np.copysign(q[..., 2], r[..., 1, 0] - r[..., 0, 1])
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, t: float) -> np.ndarray:
    """Spherical interpolation between two unit quaternions (x, y, z, w).

    :param q0: the quaternion at ``t`` 0.
    :param q1: the quaternion at ``t`` 1.
    :param t: the fraction of the way from q0 to q1.
    """
    q0 = np.asarray(q0, dtype=float)
    q1 = np.asarray(q1, dtype=float)
    d = float(np.dot(q0, q1))
    if d < 0.0:
        q1, d = -q1, -d
    if d > 0.9995:
        q = q0 + t * (q1 - q0)
        return q / np.linalg.norm(q)
    theta = np.arccos(d)
    s = np.sin(theta)
    return (np.sin((1 - t) * theta) * q0 + np.sin(t * theta) * q1) / s


def make_transform(rotation: npt.ArrayLike | None = None,
                   translation: npt.ArrayLike | None = None) -> np.ndarray:
    """Return a 4x4 transform of a rotation and a translation.

    :param rotation: 3x3; None: identity.
    :param translation: (3,); None: zero.
    """
    t = np.eye(4)
    if rotation is not None:
        t[:3, :3] = rotation
    if translation is not None:
        t[:3, 3] = translation
    return t


def invert_transform(t: np.ndarray) -> np.ndarray:
    """Return the inverse of a rigid 4x4 transform.

    :param t: a rigid 4x4 transform.
    """
    out = np.eye(4)
    out[:3, :3] = t[:3, :3].T
    out[:3, 3] = -t[:3, :3].T @ t[:3, 3]
    return out


def apply_transform(t: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 transform to (N,3) points.

    :param t: a 4x4 transform.
    :param points: (N, 3) points.
    """
    return points @ t[:3, :3].T + t[:3, 3]


def snapped_to_axis(v: npt.ArrayLike, degrees: float = 15.0) -> np.ndarray:
    """Return unit ``v``, on the nearest axis if it is within ``degrees`` of one.

    A leaning spine is not a tilted world.

    :param v: a direction, (3,), any length but zero.
    :param degrees: how far from an axis a direction is taken as that axis.
    """
    v = np.asarray(v, float) / np.linalg.norm(v)
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) >= np.cos(np.radians(degrees)):
        out = np.zeros(3)
        out[k] = np.sign(v[k])
        return out
    return v


def rotation_between(a: npt.ArrayLike, b: npt.ArrayLike) -> np.ndarray:
    """Return the smallest rotation taking unit ``a`` onto unit ``b`` (a half turn if opposite).

    :param a: the direction turned, (3,), unit.
    :param b: where it goes, (3,), unit.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    axis = np.cross(a, b)
    s, c = np.linalg.norm(axis), float(a @ b)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        axis = np.cross(a, np.eye(3)[int(np.argmin(np.abs(a)))])
        s = 0.0
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + s * k + (1 - c) * (k @ k)
