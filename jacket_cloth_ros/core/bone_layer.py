# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""M1/M2: the jacket's own bones, a layer over the character's skeleton.

- M1 sleeves: each arm link carries a main bone (the link's frame) and a twist bone halfway to
  the next link that takes a share of that link's twist about the segment, so a turned wrist
  does not wring the sleeve at one point. A simulation follows the twist from solve to solve
  (within half a turn of the last), so a wrist rolled past a half turn does not flip the bone.
- M2 upper jacket: a shoulder-pad bone on the torso aims (look-at) at a point on the upper arm,
  so a raised arm lifts the pad; the bone below hangs from the pad's end and is aimed straight
  down in the upper jacket's frame (undoing the pad's rotation); a left/right position
  constraint keeps the two bones below at their rest distance, against the stretch the moving
  pads cause. Solved every step from the current skeleton pose, nothing baked. The upper
  jacket's frame (front, left, up) is the torso link's turned by ``rpy_deg``, else the rig's
  forward and up at the zero pose: no link axis is taken for down.

The pinned top row of the cloth (M6) is skinned to the bones below the pads (see Rig), so the
cloth follows the upper jacket as it does in the article.
"""

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .bundles import LayerModel, floats, ints
from .config import ConfigError, Section
from .physics.pose import solve_layer
from .transforms import apply_transform

if TYPE_CHECKING:           # for the annotations only
    from .skeleton import Skeleton

# A bone aimed straight down, in the upper jacket's (front, left, up) axes: x = -up, y = left,
# z = front.
DOWN = np.array([[0.0, 0.0, 1.0],
                 [0.0, 1.0, 0.0],
                 [-1.0, 0.0, 0.0]])


@dataclass
class Sleeve:
    name: str
    link: int
    end_link: int           # the link itself where the sleeve ends at a point of it (``end``)
    twist_share: float
    axis: np.ndarray        # unit, link frame: towards end_link (or the end point)
    length: float
    rest: np.ndarray        # end_link's rotation in the link's frame at the zero pose


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
    parents: np.ndarray     # skeleton link index of each bone's parent frame
    rotations: np.ndarray   # (B,3,3)
    positions: np.ndarray   # (B,3)
    tips: np.ndarray        # (B,3) where each bone ends, for drawing
    below: np.ndarray       # (2,4,4) left and right bones below the pads, (0,4,4) if none


class BoneLayer:
    """The M1 sleeves and M2 upper-jacket bones of a rig (the ``jacket_bones`` section).

    :param section: the rig's ``jacket_bones`` section.
    :param skeleton: the skeleton the rig is fitted to.
    :param rest: every link's world transform at rest, (L, 4, 4).
    :param where: the section's place in the rig file, for error messages.
    :param axes_at: the body part's axes at a link (``axes_at(link, part)``, 3x3); None: the link's
        own.
    """

    def __init__(self, section: Section, skeleton: 'Skeleton', rest: np.ndarray, where: str,
                 axes_at: Callable[..., np.ndarray] | None = None):
        self.sleeves = []
        for i, s in enumerate(section.sections('sleeves')):
            link = skeleton.link(s.text('link'), f'{where}.sleeves[{i}].link')
            if s.has('end'):
                # An arm that ends at the elbow: the sleeve runs to a point of its own link
                # (rigging.propose sizes it from the link's inertia); it has no twist.
                end, offset = link, np.array(s.vector('end', 3, lo=-5.0, hi=5.0))
                key = f'{where}.sleeves[{i}].end'
            else:
                end = skeleton.link(s.text('end_link'), f'{where}.sleeves[{i}].end_link')
                offset = apply_transform(np.linalg.inv(rest[link]), rest[end][:3, 3][None])[0]
                key = f'{where}.sleeves[{i}].end_link'
            length = float(np.linalg.norm(offset))
            if length < 1e-6:
                raise ConfigError(f'{key}: must not sit on link')
            self.sleeves.append(Sleeve(
                s.text('name', 'jacket_' + skeleton.link_names[link]), link, end,
                s.number('twist_share', 0.5, lo=0.0, hi=1.0), offset / length, length,
                (rest[link][:3, :3].T @ rest[end][:3, :3]).T.copy()))
            s.reject_unknown()
        self.pads = []
        self.upper_link = None
        self.skin_radius = 0.0
        self.down = DOWN              # the bone below's axes and the pads' side, torso frame
        self.side = np.array([0.0, 1.0, 0.0])
        if section.has('upper'):
            self._load_upper(section.section('upper'), skeleton, f'{where}.upper',
                             axes_at or (lambda link, part=None: np.eye(3)))
        section.reject_unknown()
        self.names = ([s.name for s in self.sleeves] + [s.name + '_twist' for s in self.sleeves]
                      + [p.name for p in self.pads] + [p.below_name for p in self.pads])
        self.parents = [s.link for s in self.sleeves] * 2 + [self.upper_link] * 2 * len(self.pads)
        self.parent_index = np.array(self.parents, dtype=np.int64)
        self.rest_gap = 0.0
        self.model = layer_model(self)
        if self.pads:
            self.rest_gap = self.pad_ends_gap(rest)
            self.model = layer_model(self)

    def _load_upper(self, upper, skeleton, where, axes_at):
        self.upper_link = skeleton.link(upper.text('link'), f'{where}.link')
        axes = axes_at(self.upper_link, upper)
        self.down = axes @ DOWN
        self.side = axes[:, 1].copy()
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

    def pad_ends_gap(self, links: np.ndarray) -> float:
        """Distance between the two pad ends before the left/right constraint: their tips.

        :param links: every link's world transform, (L, 4, 4).
        :returns: the gap in metres.
        """
        pose = self.solve(links)
        first = 2 * len(self.sleeves)
        return float(np.linalg.norm(pose.tips[first + 1] - pose.tips[first]))

    def solve(self, links: np.ndarray, full: bool = True,
              twist: np.ndarray | None = None) -> LayerPose:
        """Every layer bone for one skeleton pose (M1 sleeves, M2 pads and bones below).

        Compiled: physics.pose.solve_layer.

        :param links: every link's world transform, (L, 4, 4).
        :param full: False solves only what the cloth needs each step: the bones below the pads.
        :param twist: (S,) each sleeve's twist to follow, moved on to this pose's (a
            simulation's StepOutput.sleeve_twist; NaN: none yet); None: the twist as it comes,
            within half a turn of zero.
        """
        n = len(self.names) if full else 0
        rot, pos, tips = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3))
        below = np.empty((len(self.pads), 4, 4))
        solve_layer(links, self.model, full, rot, pos, tips, below,
                    np.full(len(self.sleeves), np.nan) if twist is None else twist)
        return LayerPose(self.names, self.parent_index, rot, pos, tips, below)


def layer_model(layer: 'BoneLayer | None' = None) -> LayerModel:
    """Return a core.bone_layer.BoneLayer's arrays; an empty layer for ``None``.

    :param layer: the layer, or None for a rig without one.
    """
    if layer is None:
        return LayerModel(ints([]), ints([]), floats(np.zeros((0, 3))), floats([]), floats([]),
                          floats(np.zeros((0, 3, 3))),
                          0, floats(np.zeros((0, 3))), ints([]), floats(np.zeros((0, 3))),
                          floats([]), floats([]), floats(DOWN), floats([0.0, 1.0, 0.0]), 0.0)
    s, p = layer.sleeves, layer.pads
    return LayerModel(
        ints([x.link for x in s]), ints([x.end_link for x in s]),
        floats(np.array([x.axis for x in s]).reshape(-1, 3)), floats([x.length for x in s]),
        floats([x.twist_share for x in s]),
        floats(np.array([x.rest for x in s]).reshape(-1, 3, 3)), int(layer.upper_link if p else 0),
        floats(np.array([x.pivot for x in p]).reshape(-1, 3)), ints([x.aim_link for x in p]),
        floats(np.array([x.aim for x in p]).reshape(-1, 3)), floats([x.length for x in p]),
        floats([x.below_length for x in p]), floats(layer.down), floats(layer.side),
        float(layer.rest_gap))
