# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""M1/M2: the jacket's own bones, a layer over the character's skeleton.

- M1 sleeves: each arm link carries a main bone (the link's frame) and a twist bone halfway to
  the next link that takes a share of that link's twist about the segment, so a turned wrist
  does not wring the sleeve at one point.
- M2 upper jacket: a shoulder-pad bone on the torso aims (look-at) at a point on the upper arm,
  so a raised arm lifts the pad; the bone below hangs from the pad's end and is aimed straight
  down in the torso frame (undoing the pad's rotation); a left/right position constraint keeps
  the two bones below at their rest distance, against the stretch the moving pads cause.
  Solved every step from the current skeleton pose, nothing baked.

The pinned top row of the cloth (M6) is skinned to the bones below the pads (see Rig), so the
cloth follows the upper jacket as it does in the article.
"""

from dataclasses import dataclass

import numpy as np

from .config import ConfigError
from .transforms import apply_transform

DOWN = np.array([[0.0, 0.0, 1.0],     # a bone aimed straight down: x = -z, y = y, z = x
                 [0.0, 1.0, 0.0],
                 [-1.0, 0.0, 0.0]])


@dataclass
class Sleeve:
    name: str
    link: int
    end_link: int
    twist_share: float
    axis: np.ndarray        # unit, link frame: towards end_link
    length: float


@dataclass
class ShoulderPad:
    name: str
    below_name: str
    pivot: np.ndarray       # in the upper link's frame
    aim_link: int
    aim: np.ndarray         # in the aim link's frame
    length: float
    below_length: float


@dataclass
class LayerPose:
    """Bone frames of the layer in the simulation frame, and the bones below the pads."""

    names: list
    parents: list           # skeleton link index of each bone's parent frame
    rotations: np.ndarray   # (B,3,3)
    positions: np.ndarray   # (B,3)
    tips: np.ndarray        # (B,3) where each bone ends, for drawing
    below: np.ndarray       # (2,4,4) left and right bones below the pads, (0,4,4) if none


def twist_angle(rotation, axis):
    """The twist part of ``rotation`` about the unit ``axis`` (swing-twist split), radians."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(rotation))) / 2
    v = np.array([rotation[2, 1] - rotation[1, 2], rotation[0, 2] - rotation[2, 0],
                  rotation[1, 0] - rotation[0, 1]])
    v = v / (4 * w) if w > 1e-6 else _axis_of_half_turn(rotation)
    return 2 * np.arctan2(v @ axis, w)


def _axis_of_half_turn(rotation):
    k = int(np.argmax(np.diag(rotation)))
    axis = (rotation[:, k] + np.eye(3)[:, k]) / 2
    return axis / np.linalg.norm(axis)


def axis_angle(axis, angle):
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def _cross(a, b):
    # np.cross costs some 40 us per call on 3-vectors (axis juggling); this is the same sum.
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


def aim_frame(x_axis, y_hint):
    """Look-at: x along ``x_axis``, y as close to ``y_hint`` as an orthonormal frame allows."""
    x = x_axis / np.sqrt(x_axis @ x_axis)
    z = _cross(x, y_hint)
    z /= np.sqrt(z @ z)
    return np.column_stack([x, _cross(z, x), z])


class BoneLayer:
    """The M1 sleeves and M2 upper-jacket bones of a rig (the ``jacket_bones`` section)."""

    def __init__(self, section, skeleton, rest, where):
        self.sleeves = []
        for i, s in enumerate(section.sections('sleeves')):
            link = skeleton.link(s.text('link'), f'{where}.sleeves[{i}].link')
            end = skeleton.link(s.text('end_link'), f'{where}.sleeves[{i}].end_link')
            offset = apply_transform(np.linalg.inv(rest[link]), rest[end][:3, 3][None])[0]
            length = float(np.linalg.norm(offset))
            if length < 1e-6:
                raise ConfigError(f'{where}.sleeves[{i}].end_link: must not sit on link')
            self.sleeves.append(Sleeve(
                s.text('name', 'jacket_' + skeleton.link_names[link]), link, end,
                s.number('twist_share', 0.5, lo=0.0, hi=1.0), offset / length, length))
            s.reject_unknown()
        self.pads = []
        self.upper_link = None
        self.skin_radius = 0.0
        if section.has('upper'):
            self._load_upper(section.section('upper'), skeleton, f'{where}.upper')
        section.reject_unknown()
        self.names = ([s.name for s in self.sleeves] + [s.name + '_twist' for s in self.sleeves]
                      + [p.name for p in self.pads] + [p.below_name for p in self.pads])
        self.parents = [s.link for s in self.sleeves] * 2 + [self.upper_link] * 2 * len(self.pads)
        self._rest_gap = self._pad_ends(rest)[2] if self.pads else None

    def _load_upper(self, upper, skeleton, where):
        self.upper_link = skeleton.link(upper.text('link'), f'{where}.link')
        pads = upper.section('shoulder_pads')
        for side in ('left', 'right'):
            p = pads.section(side)
            key = f'{where}.shoulder_pads.{side}'
            self.pads.append(ShoulderPad(
                p.text('name', f'jacket_shoulder_pad_{side}'),
                p.text('below_name', f'jacket_chest_{side}'),
                np.array(p.vector('pivot')),
                skeleton.link(p.text('aim_link'), f'{key}.aim_link'),
                np.array(p.vector('aim')),
                p.number('length', lo=0.01, hi=1.0),
                p.number('below_length', lo=0.01, hi=2.0)))
            p.reject_unknown()
        pads.reject_unknown()
        self.skin_radius = upper.number('skin_radius', 0.2, lo=0.0, hi=2.0)
        upper.reject_unknown()

    def _pad_ends(self, links):
        torso = links[self.upper_link]
        frames, ends = [], []
        for p in self.pads:
            pivot = torso[:3, :3] @ p.pivot + torso[:3, 3]
            target = apply_transform(links[p.aim_link], p.aim[None])[0]
            frame = aim_frame(target - pivot, torso[:3, 1])
            frames.append((pivot, frame))
            ends.append(pivot + p.length * frame[:, 0])
        return frames, ends, float(np.linalg.norm(ends[1] - ends[0]))

    def solve(self, links, full=True):
        """Every layer bone for one skeleton pose (M1 sleeves, M2 pads and bones below).

        ``full=False`` solves only what the cloth needs each step: the bones below the pads.
        """
        rot, pos, tips = [], [], []
        for s in (self.sleeves if full else ()):
            t = links[s.link]
            rot.append(t[:3, :3])
            pos.append(t[:3, 3])
            tips.append(links[s.end_link][:3, 3])
        for s in (self.sleeves if full else ()):
            t, end = links[s.link], links[s.end_link]
            twist = twist_angle(t[:3, :3].T @ end[:3, :3], s.axis)
            rot.append(t[:3, :3] @ axis_angle(s.axis, s.twist_share * twist))
            pos.append(t[:3, :3] @ (s.axis * s.length / 2) + t[:3, 3])
            tips.append(end[:3, 3])
        below = np.tile(np.eye(4), (len(self.pads), 1, 1))
        if self.pads:
            frames, ends, gap = self._pad_ends(links)
            for (pivot, frame), end in zip(frames if full else (), ends):
                rot.append(frame)
                pos.append(pivot)
                tips.append(end)
            # Left/right position constraint: each bone below moves half the error.
            if gap > 1e-9:
                corr = 0.5 * (gap - self._rest_gap) / gap * (ends[1] - ends[0])
                ends = [ends[0] + corr, ends[1] - corr]
            down = links[self.upper_link][:3, :3] @ DOWN
            for k, p in enumerate(self.pads):
                if full:
                    rot.append(down)
                    pos.append(ends[k])
                    tips.append(ends[k] + down[:, 0] * p.below_length)
                below[k, :3, :3] = down
                below[k, :3, 3] = ends[k]
        return LayerPose(self.names, self.parents, np.array(rot).reshape(-1, 3, 3),
                         np.array(pos).reshape(-1, 3), np.array(tips).reshape(-1, 3), below)
