# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Level of detail by distance to a viewer, as games do it: no more model than a scene needs.

Three levels by the viewer's distance to the character's root (``lod_distances``: near, far):

- 0, nearer than ``near``: the full simulation;
- 1, up to ``far``: half the relaxation sweeps (at least one) and one substep;
- 2, beyond ``far``: only the bone layer (M1/M2) and the hood (M8); the cloth rides on its
  pinned top row (M6), each column moved as its top vertex moves, its last simulated shape kept
  (the skinned pose is not a cloth at rest and references riding the thighs distort it, so
  either would pop when the simulation takes over again), and no cloth step runs.

A change to or from level 2 blends over ``lod_blend_s``: each step's cloth is the simulated one
moved a share of the way to the riding one, the share going from ``Tuning.skin_from`` to
``skin_to`` over one input's steps (``physics.step.advance``), so nothing pops. A level
boundary is left only past it by ``HYSTERESIS``, so a viewer standing on one does not flicker.
The viewer is an input of the simulation (``JacketSimulation.set_viewer``), given in the world
frame, so a replay that feeds the same viewer positions reproduces the same steps.
"""

import math
from typing import NamedTuple

import numpy as np

from .bundles import Tuning

HYSTERESIS = 0.1            # share of a boundary's distance a viewer must cross it by


class LodStep(NamedTuple):
    """What one input's steps run with: the level and the skinned share from/to."""

    level: int
    skin_from: float
    skin_to: float


class LevelOfDetail:
    """The level and blend state of one character (no viewer: always full detail)."""

    def __init__(self) -> None:
        self.viewer = None          # (3,) world position, or None
        self.level = 0
        self.skin = 0.0             # share of the skinned pose in the published cloth
        self._tuned = (None, None, None)    # (tuning, step, the tuning at that step)

    def set_viewer(self, position: np.ndarray | None) -> None:
        """Set the viewer's world position (None: no viewer, full detail).

        :param position: the viewer's world position, (3,) metres; None: no viewer, full detail.
        """
        self.viewer = None if position is None else np.array(position, dtype=float)

    def _level_at(self, distance: float, distances: tuple) -> int:
        level = self.level
        while level < len(distances) and distance > distances[level] * (1 + HYSTERESIS):
            level += 1
        while level > 0 and distance < distances[level - 1] * (1 - HYSTERESIS):
            level -= 1
        return level

    def plan(self, root_position: np.ndarray, distances: tuple, blend_s: float,
             steps: int, dt_s: float) -> LodStep:
        """Decide the level of one input's steps, and their skinned share from and to.

        :param root_position: the skeleton root's world position, (3,) metres.
        :param distances: the viewer distances (m) at which each coarser level starts.
        :param blend_s: how long the skinned share takes to blend between 0 and 1, seconds.
        :param steps: how many steps the input runs.
        :param dt_s: each step's length, seconds.
        """
        if self.viewer is None:
            distance = 0.0
        else:
            # math.dist scales: a root far off (a bad but finite input) gives no overflow.
            distance = math.dist(self.viewer, np.asarray(root_position, dtype=float))
        self.level = self._level_at(distance, sorted(distances))
        target = 1.0 if self.level >= 2 else 0.0
        start = self.skin
        reach = steps * dt_s / blend_s if blend_s > 0 else math.inf
        self.skin = min(target, start + reach) if target > start else max(target, start - reach)
        return LodStep(self.level, start, self.skin)

    def tuned(self, tuning: Tuning, step: LodStep) -> Tuning:
        """Return ``tuning`` at ``step``'s level, the same object while neither changes.

        A character's compiled slot takes a new tuning only when the object changes
        (core/stepping.py), so a new one per input would cost the far characters what the
        level saves them.

        :param tuning: the character's full-detail tuning.
        :param step: the level the input's steps run at.
        """
        base, last, tuned = self._tuned
        if base is not tuning or last != step:
            tuned = self.tuning(tuning, step)
            self._tuned = (tuning, step, tuned)
        return tuned

    @staticmethod
    def tuning(tuning: Tuning, step: LodStep) -> Tuning:
        """Return ``tuning`` as the compiled steps take it at ``step``'s level.

        :param tuning: the character's full-detail tuning.
        :param step: the level the input's steps run at.
        """
        if step.level == 0 and step.skin_from == step.skin_to == 0.0:
            return tuning
        if step.level >= 1:
            tuning = tuning._replace(iterations=max(1, tuning.iterations // 2), max_substeps=1)
        return tuning._replace(skin_from=float(step.skin_from), skin_to=float(step.skin_to))
