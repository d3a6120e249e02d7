# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Procedural clips for the shipped character, in closed form of time.

Closed form means the same motion sampled at any rate gives the same poses at the same times,
which the frame-rate tests rely on. A pose is the joint values and the root's world pose
(x, y, z, yaw); the root stands 0.96 m above the floor.
"""

from collections.abc import Sequence

import numpy as np

from ..core.inputs import WORLD_VARIABLES

STAND = 0.96


def smoothstep(s: 'float | np.ndarray') -> 'float | np.ndarray':
    """Return 0 before 0, 1 after 1, and an ease-in-out between (3s² - 2s³).

    :param s: where in the blend, 0 to 1 (outside: held at the ends).
    """
    s = np.clip(s, 0.0, 1.0)
    return s * s * (3 - 2 * s)


def _idle(t):
    b = np.sin(2 * np.pi * 0.25 * t)
    return {'spine_pitch': 0.02 * b, 'neck_pitch': -0.02 * b,
            'l_elbow': -0.1, 'r_elbow': -0.1}, (0.0, 0.0, 0.0, 0.0)


def _gait(t, freq, hip, knee, arm, elbow, lean, speed, bob):
    phase = 2 * np.pi * freq * t
    s = np.sin(phase)
    q = {'l_hip_pitch': -hip * s, 'r_hip_pitch': hip * s,
         'l_knee': knee * max(0.0, np.sin(phase - 1.2)),
         'r_knee': knee * max(0.0, -np.sin(phase - 1.2)),
         'l_shoulder_pitch': arm * s, 'r_shoulder_pitch': -arm * s,
         'l_elbow': -elbow, 'r_elbow': -elbow,
         'spine_pitch': lean, 'spine_yaw': 0.12 * s, 'neck_pitch': -0.5 * lean}
    return q, (speed * t, 0.0, bob * np.cos(2 * phase), 0.0)


def _walk(t):
    return _gait(t, 0.9, 0.45, 0.7, 0.35, 0.3, 0.04, 1.4, 0.02)


def _run(t):
    return _gait(t, 1.4, 0.8, 1.4, 0.7, 1.3, 0.25, 3.6, 0.05)


def _dodge(t):
    s = smoothstep((t - 0.3) / 0.35)
    crouch = np.exp(-((t - 0.5) / 0.25) ** 2)
    q = {'l_knee': 0.9 * crouch, 'r_knee': 0.9 * crouch, 'l_hip_pitch': -0.6 * crouch,
         'r_hip_pitch': -0.6 * crouch, 'spine_pitch': 0.4 * crouch, 'l_hip_roll': 0.3 * crouch,
         'l_shoulder_roll': 0.6 * crouch, 'r_shoulder_roll': -0.3 * crouch}
    return q, (0.0, 1.3 * s, -0.15 * crouch, 0.0)


def _jump(t):
    crouch = np.exp(-((t - 0.25) / 0.1) ** 2) + np.exp(-((t - 1.05) / 0.1) ** 2)
    s = np.clip((t - 0.35) / 0.6, 0.0, 1.0)
    air = 4 * 0.5 * s * (1 - s)
    tuck = np.sin(np.pi * s)
    q = {'l_knee': 1.1 * crouch + 0.8 * tuck, 'r_knee': 1.1 * crouch + 0.8 * tuck,
         'l_hip_pitch': -0.8 * crouch - 0.6 * tuck, 'r_hip_pitch': -0.8 * crouch - 0.6 * tuck,
         'l_shoulder_roll': 1.2 * tuck, 'r_shoulder_roll': -1.2 * tuck,
         'spine_pitch': 0.3 * crouch}
    return q, (0.0, 0.0, air - 0.2 * crouch, 0.0)


def _arms_up(t):
    s = smoothstep((t - 0.2) / 1.0)
    return {'l_shoulder_roll': 2.8 * s, 'r_shoulder_roll': -2.8 * s,
            'l_elbow': -0.2 * s, 'r_elbow': -0.2 * s}, (0.0, 0.0, 0.0, 0.0)


def _turn(t):
    s = smoothstep((t - 0.4) / 0.6)
    q, _ = _idle(t)
    step = np.sin(np.pi * s)
    q.update({'l_hip_pitch': -0.3 * step, 'r_knee': 0.4 * step, 'spine_yaw': 0.3 * step})
    return q, (0.0, 0.0, 0.0, np.pi * s)


def _teleport(t):
    q, (x, y, z, yaw) = _walk(t)
    return q, (x + (10.0 if t >= 1.5 else 0.0), y, z, yaw)


CLIPS = {  # name: (pose function of local time, length in s for sequences)
    'idle': (_idle, 3.0), 'walk': (_walk, 4.0), 'run': (_run, 3.0), 'dodge': (_dodge, 1.6),
    'jump': (_jump, 1.6), 'arms_up': (_arms_up, 2.5), 'turn': (_turn, 1.6),
    'teleport': (_teleport, 3.0),
}
# The moment of each clip worth a picture (s into the clip).
HIGHLIGHT = {'idle': 1.5, 'walk': 2.2, 'run': 1.6, 'dodge': 0.55, 'jump': 0.65, 'arms_up': 2.0,
             'turn': 0.75, 'teleport': 1.7}
SHOWCASE = ('idle', 'walk', 'run', 'dodge', 'jump', 'arms_up', 'turn', 'walk', 'teleport')
ALL_CLIPS = tuple(CLIPS) + ('showcase',)


def _compose(base, local):
    """Root pose ``local`` (x, y, z, yaw) expressed after ``base``."""
    bx, by, bz, byaw = base
    x, y, z, yaw = local
    c, s = np.cos(byaw), np.sin(byaw)
    return (bx + c * x - s * y, by + s * x + c * y, bz + z, byaw + yaw)


def clip_length(name: str) -> float:
    """Return a clip's length in seconds (the showcase: its clips' together).

    :param name: a name of ``ALL_CLIPS``.
    """
    if name == 'showcase':
        return sum(CLIPS[n][1] for n in SHOWCASE)
    return CLIPS[name][1]


def segment_at(name: str, t: float) -> tuple[str, float, tuple[float, float, float, float]]:
    """(segment name, local time, root pose at the segment start) of a clip at time t.

    :param name: a name of ``ALL_CLIPS``.
    :param t: seconds from the clip's start.
    """
    if name != 'showcase':
        return name, t, (0.0, 0.0, 0.0, 0.0)
    base = (0.0, 0.0, 0.0, 0.0)
    for seg in SHOWCASE:
        f, length = CLIPS[seg]
        if t < length or seg == SHOWCASE[-1]:
            return seg, t, base
        _, end = f(length)
        base = _compose(base, (end[0], end[1], 0.0, end[3]))
        t -= length
    raise AssertionError('unreachable')


def pose(name: str, t: float) -> tuple[dict[str, float], tuple[float, ...]]:
    """Return joint values {name: value} and the root's world pose as x, y, z, qx, qy, qz, qw.

    :param name: a name of ``ALL_CLIPS``.
    :param t: seconds from the clip's start.
    """
    if name not in ALL_CLIPS:
        raise ValueError(f'unknown clip {name!r} (clips: {", ".join(ALL_CLIPS)})')
    seg, local_t, base = segment_at(name, t)
    q, local = CLIPS[seg][0](local_t)
    x, y, z, yaw = _compose(base, local)
    root = (x, y, STAND + z, 0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2))
    return {k: float(v) for k, v in q.items()}, tuple(float(v) for v in root)


# Clips whose closed form goes on past their length (a gait, breathing): played on, not looped.
ENDLESS = ('idle', 'walk', 'run')
# A loop of another clip starts from the pose the last one ended in, turning to its own first
# pose over this long (s).
LOOP_BLEND_S = 0.4


def looped_pose(name: str, t: float) -> tuple[dict[str, float], tuple[float, ...]]:
    """Return ``pose`` of a clip at any ``t``: past its end, it goes on from where it ended.

    Gaits and breathing (``ENDLESS``) run on in closed form. Another clip starts again where
    its last loop ended (its root's position and heading, never a teleport back), its joints
    turning from that loop's last pose to its first over ``LOOP_BLEND_S``.

    :param name: a name of ``ALL_CLIPS``.
    :param t: seconds from the clip's start, 0 or more.
    """
    if name not in ALL_CLIPS:
        raise ValueError(f'unknown clip {name!r} (clips: {", ".join(ALL_CLIPS)})')
    length = clip_length(name)
    if name in ENDLESS or t < length:
        return pose(name, t)
    loops, local = divmod(t, length)
    q_end, end = pose(name, length)
    base, yaw = (0.0, 0.0, 0.0, 0.0), 2 * np.arctan2(end[5], end[6])
    for _ in range(int(loops)):
        base = _compose(base, (end[0], end[1], 0.0, yaw))
    q, root = pose(name, local)
    here = _compose(base, (root[0], root[1], 0.0, 2 * np.arctan2(root[5], root[6])))
    s = float(smoothstep(local / LOOP_BLEND_S))
    z = root[2] + (1 - s) * (end[2] - pose(name, 0.0)[1][2])
    q = {k: s * q.get(k, 0.0) + (1 - s) * q_end.get(k, 0.0) for k in set(q) | set(q_end)}
    return q, (here[0], here[1], z, 0.0, 0.0, float(np.sin(here[3] / 2)),
               float(np.cos(here[3] / 2)))


def joint_state_content(joint_names: Sequence[str], name: str, t: float,
                        world_joint: str = 'world_joint',
                        looped: bool = False) -> tuple[list[str], list[float]]:
    """(names, positions) of a JointState for the clip at time t: every joint plus the root.

    :param joint_names: the skeleton's joints, every one given a value.
    :param name: a name of ``ALL_CLIPS``.
    :param t: seconds from the clip's start.
    :param world_joint: the prefix of the root's variables (``world_joint/trans_x`` ...).
    :param looped: past the clip's end, go on as ``looped_pose`` does; else the closed form
        holds on (``pose``).
    """
    q, root = looped_pose(name, t) if looped else pose(name, t)
    names = list(joint_names) + [f'{world_joint}/{v}' for v in WORLD_VARIABLES]
    return names, [q.get(j, 0.0) for j in joint_names] + list(root)


def clip_joints(name: str, samples: int = 64) -> set[str]:
    """Return the joints a clip moves (those its poses name), sampled over its length.

    :param name: a name of ``ALL_CLIPS``.
    :param samples: poses sampled, evenly over the clip.
    """
    length = clip_length(name)
    return set().union(*(pose(name, length * k / samples)[0] for k in range(samples + 1)))


def showcase_highlights() -> list[tuple[float, str]]:
    """(time in the showcase, segment name) of each segment's highlight."""
    out, start = [], 0.0
    for seg in SHOWCASE:
        out.append((start + HIGHLIGHT[seg], seg))
        start += CLIPS[seg][1]
    return out
