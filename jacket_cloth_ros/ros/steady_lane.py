# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A lone character's steady input in one compiled call: JointState bytes in, /tf bytes out.

The node's and the replay's common input (the name list of the last one, a stamp a step or
two on) is read from its CDR bytes, checked and loaded by the armed intake, stepped, its bones
posed and its /tf laid out, with no Python between (core/stepping.py arms the intake). The
caller publishes that /tf at once and does the input's bookkeeping afterwards
(SessionPipeline.steady_tf). Any other input (another name list, bytes the compiled reader
does not take, a stamp before 1970, an input the intake refuses) leaves everything as it was:
NOT_STEADY, and the input goes cdr.JointStateReader's and JacketSimulation.process's way,
which say what is wrong.
"""

import numpy as np

from ..core.compiled import njit
from ..core.physics import step
from ..core.physics.crowd import BONES_FINITE, NOT_STEADY, step_steady
from .cdr import put_rows, put_stamp


@njit(cache=True)
def _u32(raw, at):
    """Return the little-endian uint32 at byte ``at`` as an int64.

    Not as numba's unsigned integers: mixed with signed ones, they turn into floats.
    """
    value = np.int64(0)
    for k in range(4):
        value |= np.int64(raw[at + k]) << (8 * k)
    return value


@njit(cache=True)
def _aligned(at, n):
    """``at`` moved on to a multiple of ``n`` from the end of the encapsulation header."""
    return at + (-(at - 4)) % n


@njit(cache=True)
def read_steady(raw, names, positions):
    """Read a JointState's stamp and positions if it has these name bytes; else -1.

    As cdr.JointStateReader.read does: CDR_LE only, the name sequence recognised by its bytes
    (``names``, the reader's name_code: -1 where any byte will do), the positions copied into
    ``positions`` (the intake's buffer as bytes), whose length they must have. Returns the
    stamp, ns, or -1 when the bytes are anything else (the reader then reads them, or says why
    it cannot).
    """
    n = raw.shape[0]
    if n < 16 or raw[0] != 0 or raw[1] != 1 or names.shape[0] == 0:
        return -1
    sec = _u32(raw, 4)
    if sec >= 2 ** 31:          # int32
        sec -= 2 ** 32
    nanosec = _u32(raw, 8)
    at = _aligned(16 + _u32(raw, 12), 4)
    m = names.shape[0]
    if at + m > n:
        return -1
    for i in range(m):
        if names[i] >= 0 and raw[at + i] != names[i]:
            return -1
    at = _aligned(at + m, 4)
    if at + 4 > n:
        return -1
    count = _u32(raw, at)
    at = _aligned(at + 4, 8)
    size = positions.shape[0]
    if 8 * count != size or at + size > n:
        return -1
    for i in range(size):
        positions[i] = raw[at + i]
    return sec * 1_000_000_000 + nanosec


@njit(cache=True, nogil=True)
def steady_tf(raw, names, lane, tf):
    """One steady input from its bytes to its /tf's bytes: (status, stamp ns, /tf laid out).

    ``lane``: core.stepping.Stepper.lane, a typed list of one (the intake's positions buffer
    as float64 values and as bytes, the intake, the slot); ``tf``: the /tf
    template's (u32 view, stamp indices, f64 view, pose indices) (cdr.TfTemplate.layout).
    NOT_STEADY: nothing moved. Else physics.crowd's status of the steps run; the /tf is laid
    out only for bones the simulation publishes as they are (finite, from a finite cloth):
    any other outcome is reset first, in Python, and its /tf made there.
    """
    # Borrowed (core.stepping.Stepper keeps the arrays): taken out with no reference counted.
    positions, positions_bytes, intake, slot = lane[0]
    stamp = read_steady(raw, names, positions_bytes)
    if stamp < 0:
        return NOT_STEADY, stamp, False
    status = step_steady(intake, slot, stamp, positions)
    if status != BONES_FINITE or slot.out.stats[step.NON_FINITE] != 0.0:
        return status, stamp, False
    u32, stamp_at, f64, pose_at = tf
    put_rows(f64, pose_at, slot.bones)
    put_stamp(u32, stamp_at, stamp)
    return status, stamp, True
