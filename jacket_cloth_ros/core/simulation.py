# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The fixed-step jacket and hood simulation driven by skeleton samples (one door for all).

The node, the offline replay and the lab all call :meth:`JacketSimulation.process` with the
JointState content and its header stamp, so a recorded session replays exactly as it ran live.

Time: steps sit on a grid of ``1/sim_rate`` (integer nanoseconds) anchored at the first stamp
(M7); the skeleton is interpolated between samples for the steps in between; at most
``max_steps_per_input`` steps run per sample so a hitch cannot snowball.
Space: the cloth lives in the character's local frame (the URDF root) and feels 100% of the
skeletal motion but only ``world_share`` of the world motion (M14).
"""

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .body_proxy import lowest_reach
from .bone_layer import LayerPose
from .bundles import (
    ClothState, Colliders, CrowdSlot, JointSample, StepControl, StepOutput, Tuning, copied,
    floats, ints, posed_like, step_scratch)
from .inputs import InputParser, InputRejected, Sample
from .lod import LevelOfDetail
from .measures import (COLLAPSED_FOR_S, RESTLESS_FOR_S, CollapseWatch, FloorWatch,
                       RestlessWatch, Worst, collider_labels, depth_inside, edge_strain)
from .params import AUTO_TELEPORT_PER_HEIGHT, SimParams
from .physics import cloth, colliders, hood, pose, step
from .physics.sampling import root_jump
from .rig import collider_model, model_of
from .stepping import (BONES_FINITE, NOT_STEADY, STEPS_FAILED, StepJob, Stepper,
                       identity_poses)

if TYPE_CHECKING:           # for the annotations only
    from .fabric import Fabric
    from .rig import Rig
    from .skeleton import Skeleton


_NO_BELOW = np.zeros((0, 4, 4))          # a rig without M2 pads: the top row rides its link
_NO_LAYER_POSE = LayerPose([], np.zeros(0, dtype=np.int64), np.zeros((0, 3, 3)), np.zeros((0, 3)),
                           np.zeros((0, 3)), _NO_BELOW)
# Fabrics are tuned at this rate: their damping is the share of velocity lost per 1/120 s and
# their stiffness is what one step of this length does (see per_step and xpbd_compliance).
DESIGN_RATE = 120.0
# The reset reason of an input whose bones were not finite (JacketSimulation.check_bones).
NONFINITE_BONES = 'non-finite bones'
# Deeper than this share of its height under the floor, the body itself is said to be what
# fights the cloth: the shapes that stand for feet sink about that far in a captured stride.
UNDER_FLOOR_PER_HEIGHT = 0.05
# The root stood on the rig's floor (or at the origin), a guess, until the source sent its
# world pose: the cloth restarts there rather than fall or fly the way between, which no
# motion made.
WORLD_BEGAN = 'the world pose began (the root was placed without one before)'
# Within this share of the height and these degrees of the guess, the world pose is the guess
# confirmed: no restart.
GUESS_KEPT_PER_HEIGHT, GUESS_KEPT_DEG = 0.005, 1.0
# The cloth inside a collider at the zero pose deeper than this (m) is named at load.
INSIDE_AT_REST = 0.005
# The cloth stretched more than this share at the first input is named (issue 19's target).
STRETCHED_AT_START = 0.10
# Automatic quality mode: relaxation stops once a sweep moves nothing by more than this share of
# the tolerance. Chosen by the lab (walk and idle, 2 s, against the converged reference): at 0.1
# the hem drifted past the tolerance (14 mm RMS at 10 mm); at 0.03 it stayed within it.
AUTO_SWEEP_SHARE = 0.03


def per_step(share: npt.ArrayLike, exponent: float) -> float | np.ndarray:
    """Return a share lost per design step as the share lost in a step ``exponent`` times as long.

    The compiled step's formula: physics.step.lost_per.

    :param share: the share lost per design step (1 / DESIGN_RATE s), one or an array.
    :param exponent: the step's length in design steps.
    """
    if np.ndim(share) == 0:
        return step.lost_per(float(share), float(exponent))
    out = np.empty(np.shape(share))
    step.lost_per_each(floats(share), float(exponent), out)
    return out


def xpbd_compliance(stiffness: npt.ArrayLike, iterations: int) -> np.ndarray | float:
    """Return the XPBD compliance (m/N at unit mass) matching the article's relaxation.

    One design step of XPBD with it is as stiff as ``iterations`` sweeps of ``stiffness``.
    For one constraint between two unit masses, n sweeps of stiffness k correct a share
    k_n = 1 - (1 - k)^n of the error, and XPBD corrects 2 / (2 + alpha / dt^2), so
    alpha = 2 dt^2 (1 - k_n) / k_n with dt = 1 / DESIGN_RATE. Stiffness 1 gives alpha = 0.

    :param stiffness: the share of the error a sweep corrects, one or an array.
    :param iterations: the sweeps per design step.
    """
    k = 1.0 - (1.0 - np.asarray(stiffness, dtype=float)) ** iterations
    with np.errstate(divide='ignore'):
        alpha = 2.0 * (1.0 - k) / np.maximum(k, 1e-12) / DESIGN_RATE ** 2
    return alpha


@dataclass(slots=True)
class Bones:
    """Bone frames: ``parents[i]`` is a skeleton link; poses are relative to that link."""

    names: list
    parents: list
    poses: np.ndarray          # (B,7): translation, then quaternion x, y, z, w
    finite: bool = True        # False if any number is not (never to be published)

    @property
    def translations(self) -> np.ndarray:
        return self.poses[:, :3]

    @property
    def quaternions(self) -> np.ndarray:
        return self.poses[:, 3:]


@dataclass(frozen=True, slots=True)
class BoneSet:
    """Every bone of a rig as published: names, parent links, and the M9 grid bones' places."""

    names: list                # M9 cloth bones, M8 hood bone, M1/M2 layer bones
    parents: list              # each one's parent link
    grid: np.ndarray           # (G,2) int64: the M9 bones' (row, column) on the cloth grid


@dataclass(slots=True)
class Faults:
    """What a simulation found wrong beyond one input's warnings (issue 35 item 5)."""

    nonfinite: int = 0              # inputs whose bones were not finite (check_bones)
    overruns: int = 0               # inputs whose steps were capped (max_steps_per_input)
    retried: int = 0                # steps too fast for their substeps, run again finer
    rig: list = field(default_factory=list)     # the rig's, at load and at the first input
    collapse: list = field(default_factory=list)    # each time the cloth stayed collapsed
    restless: list = field(default_factory=list)    # each time it kept moving, body still
    under_floor: list = field(default_factory=list)     # each time the body went under


@dataclass(slots=True)
class Watches:
    """What watches the cloth over many inputs for a failure no one input shows."""

    collapse: CollapseWatch         # bunched or stretched across for a second
    restless: RestlessWatch         # moving on while the body stays still
    floor: FloorWatch               # the body under the rig's floor

    def clear(self) -> None:
        """Forget what was seen (the cloth was put back on the body: a reset)."""
        self.collapse.clear()
        self.restless.clear()
        self.floor.clear()


@dataclass(slots=True)
class StepReport:
    """What one processed sample did, for logging, diagnostics and output."""

    stamp_ns: int
    accepted: bool = True
    steps: int = 0
    skipped_steps: int = 0
    reset: str = ''                    # why the cloth was reset to the skinned pose, if it was
    warnings: list = field(default_factory=list)
    step_cost_ns: int = 0              # wall time of the simulation work for this sample
    max_penetration: float = 0.0
    limited_vertices: int = 0          # M11 vertex-steps moved back to their bound
    sweeps: int = 0                    # relaxation sweeps run (over all steps and substeps)
    substeps: int = 0                  # substeps run (over all steps), retries' included
    retried_steps: int = 0             # steps run again in finer substeps (step.RETRIED)
    merged: bool = False               # another source's joints, taken into the last pose
    lod_level: int = 0                 # level of detail of these steps (core/lod.py)


# A profiler's hook (JacketSimulation.time_stages, ros.pipeline.SessionPipeline): called once
# per stage with the stage's name and callable, it returns the callable run in its place.
StageTimer = Callable[[str, Callable], Callable]


def deepest_at_rest(rig: 'Rig') -> Worst:
    """Return where a rig's rest cloth is deepest inside its colliders at the zero pose.

    The floor aside: the root is not where a motion puts it. A rig's own measure, with no
    simulation made: the node checks it at load, ``rig`` while it fits a proposal.

    :param rig: the rig, fitted to its skeleton.
    :returns: ``value`` (m, 0 outside), ``vertex`` and ``collider`` (its label), as
        measures.depth_inside gives them.
    """
    skeleton, model = rig.skeleton, collider_model(rig)
    now = posed_like(model, rig.n)
    colliders.collider_poses(skeleton.forward(np.zeros(len(skeleton.joint_names))), model, now)
    body = Colliders(now.centers, now.axes, floats(rig.collider_radii), now.cap_a, now.cap_b,
                     floats(rig.capsule_radii), np.zeros((0, 3)), np.zeros((0, 3)))
    return depth_inside(rig.rest, np.ones(rig.n, dtype=bool), body, collider_labels(rig))


class JacketSimulation:
    """Jacket cloth + hood pendulum for one skeleton and rig.

    As Warp's sim and MuJoCo keep a model apart from its data, the simulation holds its
    skeleton, rig and their compiled ``model`` (fixed), the fabric's and parameters' values
    as ``tuning`` (rebuilt on a live change) and the moving ``state`` (cloth, hood, root),
    each once: ``x``, ``hood_p`` and the rest are views of ``state``.

    :param skeleton: the character.
    :param rig: its jacket rig.
    :param fabric: the fabric's values.
    :param params: the simulation's parameters.
    :param world_joint: the prefix of the root's world pose variables in a JointState.
    """

    def __init__(self, skeleton: 'Skeleton', rig: 'Rig', fabric: 'Fabric',
                 params: SimParams = SimParams(), world_joint: str = 'world_joint'):
        self.skeleton = skeleton
        self.rig = rig
        self.parser = InputParser(skeleton, world_joint, floor=rig.floor())
        self.fabric = fabric
        self.params = params
        self.model = model_of(skeleton, rig)
        self.state = ClothState(floats(rig.rest).copy(), floats(rig.rest).copy(),
                                np.zeros(rig.n, dtype=np.bool_), np.zeros(3), np.zeros(3),
                                np.eye(4), np.zeros(len(rig.con_a)), np.zeros(1, dtype=np.bool_))
        # Colliders and M11 references where the last step ended: substeps start from them.
        self._before = posed_like(self.model.colliders, rig.n)
        self.tuning = self._tuning()
        self.links = skeleton.forward(np.zeros(len(skeleton.joint_names)))
        self._layer = None        # the full M1/M2 pose of self.links, solved when asked for
        self.last = None          # last accepted Sample
        self.t_sim = None         # ns of the last step
        self.resets = 0
        self.faults = Faults()
        self.steps_total = 0
        # The current state's bones, as an input's check left them (the compiled call makes
        # them with its steps, core/stepping.py); any new input or reset drops them.
        self.ready_bones = None
        self._own = None        # (last, parser's last, bones) took_steady may move on in place
        self.lod = LevelOfDetail()
        self.bone_set = bone_set(skeleton, rig)
        # The compiled steps and bones (physics.crowd.advance_slot), alone as in a crowd.
        layer = rig.layer
        q = len(skeleton.joint_names)
        self.steps = Stepper(CrowdSlot(
            self.model, self.tuning, self.state, self._before,
            step_scratch(self.model.colliders, q, len(self.state.x),
                         len(self.model.cloth.pin_local)), np.zeros(q), np.zeros(q),
            np.zeros(4), np.zeros(4), np.zeros(3), np.zeros(3), np.zeros(5, dtype=np.int64),
            self.step_output(), ints(self.bone_set.grid),
            ints(layer.parent_index if layer else []), identity_poses(len(self.bone_names))))
        c = self.model.cloth        # issue 47 item 5a: no silent collapse
        self.watches = Watches(CollapseWatch(c.horiz_a, c.horiz_b, c.horiz_rest),
                               RestlessWatch(), FloorWatch())
        self._warm_up()
        # What is wrong with the rig before any input (the node logs it at load), then at the
        # first input (with its warnings); the tools print them all (issue 35 item 5).
        self._inside = self._inside_at_rest()
        self.faults.rig = list(getattr(skeleton, 'warnings', ())) + self._inside

    # -- the state, held once in ``state`` --------------------------------------------------
    x = property(lambda self: self.state.x, lambda self, v: _put(self.state.x, v),
                 doc='(N,3) the cloth, simulation frame')
    xp = property(lambda self: self.state.xp, lambda self, v: _put(self.state.xp, v),
                  doc='(N,3) its previous positions (Verlet)')
    contact = property(lambda self: self.state.contact,
                       lambda self, v: _put(self.state.contact, v),
                       doc='(N,) bool: touched the body in the last step (M15)')
    hood_p = property(lambda self: self.state.hood_p, lambda self, v: _put(self.state.hood_p, v),
                      doc='(3,) the hood particle (M8)')
    hood_pp = property(lambda self: self.state.hood_pp,
                       lambda self, v: _put(self.state.hood_pp, v),
                       doc='(3,) its previous position')
    root = property(lambda self: self.state.root, lambda self, v: _put(self.state.root, v),
                    doc='(4,4) the root\'s world pose at the last step')

    @property
    def dt_ns(self) -> int:
        """The fixed step (ns)."""
        return int(round(1e9 / self.params.sim_rate))

    @property
    def bone_names(self) -> list:
        """Every bone's name, as published (BoneSet.names)."""
        return self.bone_set.names

    @property
    def bone_parents(self) -> list:
        """Every bone's parent link (BoneSet.parents)."""
        return self.bone_set.parents

    def _tuning(self):
        """Return the fabric's and parameters' values as the compiled step takes them."""
        p, f, rig = self.params, self.fabric, self.rig
        edge, region = rig.edge, rig.region_scale          # M13 edges, then the rig's regions
        damping = np.minimum(1.0, np.where(edge, f.edge_damping, f.damping)
                             * region['damping_scale'])                          # M4, M13
        world_share = np.minimum(1.0, np.where(edge, f.edge_world_share, f.world_share)
                                 * region['world_share_scale'])                  # M14, M13
        wind_scale = np.where(edge, f.edge_wind_scale, f.wind_scale) * region['wind_scale']
        max_distance = (rig.max_distance * np.where(edge, f.edge_max_distance_scale, 1.0)
                        * region['max_distance_scale'])                          # M11, M13
        stiffness = np.where(rig.con_group == 0, f.stretch_stiffness,
                             f.shear_bend_stiffness)                             # M5
        return Tuning(
            floats(stiffness), int(f.iterations), floats(xpbd_compliance(stiffness, f.iterations)),
            floats(max_distance), int(p.stretch_limit_mode),
            float(f.max_horizontal_stretch), int(p.solver_mode),
            int(p.substeps), float(p.quality_tolerance),
            float(AUTO_SWEEP_SHARE * p.quality_tolerance), floats(damping),
            float(f.contact_damping), float(f.hood_damping), float(DESIGN_RATE / p.sim_rate),
            floats(world_share), float(f.world_share), floats(wind_scale),
            float(f.wind_scale), float(p.gravity), floats(p.wind), float(p.wind_gust),
            float(p.wind_gust_period))

    def _warm_up(self):
        """Load (or compile) the kernels now, not on the first input, which would stall it."""
        saved = copied(self.state), copied(self._before), self.links, self._layer
        still = Sample(0, np.zeros(len(self.skeleton.joint_names)), np.eye(4),
                       np.array([0.0, 0.0, 0.0, 1.0]))
        # The first inputs also load the parser's, the reset's, the jump test's and the
        # bones' kernels, which would stall them: load them here too.
        parser = InputParser(self.skeleton, self.parser.world_joint)
        parser.parse(0, self.skeleton.joint_names, still.q)
        root_jump(still.root, still.root, still.root_quat, still.root_quat)
        self._reset(still)
        self.resets, self.last = 0, None
        self.bones()
        self.t_sim = 0
        self._run_steps(still, replace(still, stamp_ns=self.dt_ns), 1)
        self.steps.load_steady()
        self.watches.collapse.load(self.x)
        self.watches.restless.load(self.links, self.root)
        state, before, self.links, self._layer = saved
        for kept, was in zip((*self.state, *self._before), (*state, *before)):
            kept[...] = was
        self.t_sim = None

    # -- parameters -------------------------------------------------------------------------
    def set_fabric(self, fabric: 'Fabric') -> None:
        """Live change: new parameters act from the next step; the cloth is not reset.

        :param fabric: the fabric's new values.
        """
        self.fabric = fabric
        self.tuning = self._tuning()
        self.steps.retune(self.tuning)

    def set_params(self, params: SimParams) -> None:
        """Live change of the simulation's parameters, as set_fabric.

        :param params: the new parameters.
        """
        self.params = params
        self.tuning = self._tuning()
        self.steps.retune(self.tuning)

    # -- the skinned pose ---------------------------------------------------------------------
    def reference_points(self, links: np.ndarray,
                         layer: LayerPose | None = None) -> np.ndarray:
        """M11: each vertex's rest position carried by its nearest bone (see _skinned_pose).

        :param links: the link transforms (L, 4, 4) in the simulation frame.
        :param layer: the M1/M2 bones solved for ``links``; None: none.
        """
        return self._skinned_pose(links, layer)[1]

    def pinned_points(self, links: np.ndarray, layer: LayerPose | None = None) -> np.ndarray:
        """M6: where the top row is (see _skinned_pose).

        :param links: the link transforms (L, 4, 4) in the simulation frame.
        :param layer: the M1/M2 bones solved for ``links``; None: none.
        """
        return self._skinned_pose(links, layer)[0]

    def _skinned_pose(self, links, layer, outside=True):
        """(pinned top row, M11 reference points) for a skeleton pose.

        M6: the top row is carried by its link and, near the shoulders, by the M2 bones below
        the shoulder pads (``layer``, solved for ``links``), its spread held to the fabric's
        ``max_horizontal_stretch``, then put outside the colliders
        (posed with ``self.root`` for the floor), as the compiled step does. A column hangs
        from its top vertex, so the column's reference points are lifted with it, or M11 would
        pull the cloth away from its own pinned row.
        """
        rig = self.rig
        below = layer.below if layer is not None else _NO_BELOW
        top, ref = np.empty((rig.cols, 3)), np.empty((rig.n, 3))
        pose.skinned_pose(links, self.model.cloth, below, top, ref)
        cloth.hold_pinned_row(top, self.model.cloth, below.shape[0] > 0,
                              self.fabric.max_horizontal_stretch)
        if not outside:
            return top, ref
        c = self._posed(links, self.root)       # M10: the pinned row outside the body
        colliders.push_out_points(top, colliders.posed_body(self.model.colliders, c))
        return top, ref

    @property
    def layer(self) -> LayerPose | None:
        """M1/M2 bones for the current skeleton pose (solved once per pose, on demand)."""
        if self._layer is None or self._layer[0] is not self.links:
            # The sleeves' twist followed as the steps follow it: a reset pose's bones must
            # not take a wrist past a half turn the short way round.
            self._layer = (self.links, self.rig.layer.solve(
                self.links, twist=self.steps.slot.out.sleeve_twist) if self.rig.layer else None)
        return self._layer[1]

    def hood_anchor(self, links: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the hood bone's centre and its link's rotation, in the simulation frame.

        :param links: the link transforms (L, 4, 4) in the simulation frame.
        """
        t = links[self.rig.hood.link]
        return t[:3, :3] @ self.rig.hood.pivot + t[:3, 3], t[:3, :3]

    def _reset(self, sample):
        """Put the cloth and hood on the skinned pose of ``sample``."""
        self.ready_bones = None
        self.watches.clear()
        self.links = self.skeleton.forward(sample.q)
        self.root = sample.root.copy()          # the steps move it in place
        top, ref = self._skinned_pose(self.links, self.layer)
        self.x = ref.copy()
        self.x[:self.rig.cols] = top
        self.xp = self.x.copy()
        self.contact[:] = False
        anchor, rot = self.hood_anchor(self.links)
        self.hood_p = anchor + rot @ self.rig.hood.rest_direction * self.rig.hood.length
        planes = self._posed(self.links, self.root)     # a body lying down: on the floor
        hood.rest_on_planes(self.hood_p, anchor, float(self.rig.hood.length), planes.plane_p,
                            planes.plane_n)
        self.hood_pp = self.hood_p.copy()
        self.t_sim = sample.stamp_ns
        self.last = sample
        self.resets += 1
        # The skinned pose is not a cloth at rest (reference points ride different bones):
        # settle it once, constraints and collisions without motion, so no step starts from a
        # stretched grid and snaps.
        self._cloth_step(self.links, self.root, ref, np.zeros((self.rig.n, 3)),
                         np.ones(self.rig.n), 0.0, 0.0)
        self.xp = self.x.copy()
        self.contact[:] = False

    def check_bones(self, report: StepReport) -> None:
        """Make the bones of the input ``report`` tells of finite if need be; once per input.

        The door to publishing, run where an input's steps end (:meth:`process`, a crowd's
        round), never again: bones that are not finite (a vertical edge of zero length gives
        its M9 bone no direction, as when rows of the hem lie flattened on the floor) reset the
        cloth to the skinned pose (M6, M11) as a non-finite cloth does; if that pose's bones are
        not finite either (its settling step flattened it again), the cloth is laid on the
        skinned pose as it is, before the colliders. Such an input is counted in ``faults``
        and ``report.reset`` says why. Bones still not finite (a degenerate skeleton pose) are
        left as they are (:meth:`bones` says so): the caller publishes none.

        :param report: the report of the accepted input just processed; its ``reset`` is set
            if the cloth resets here.
        """
        bones = self.bones()
        if bones.finite or self.last is None:
            self.ready_bones = bones        # /tf and the markers' skinning read them
            return
        self.faults.nonfinite += 1
        report.reset = NONFINITE_BONES + self._degenerate_edge()
        self._reset(self.last)
        bones = self.bones()
        if not bones.finite:
            top, ref = self._skinned_pose(self.links, self.layer, outside=False)
            self.x = ref
            self.x[:self.rig.cols] = top
            self.xp = self.x
            self.contact[:] = False
            bones = self.bones()
        self.ready_bones = bones

    def _degenerate_edge(self) -> str:
        """Say which vertical edge of the cloth is shortest when it has no length, else ''."""
        rig = self.rig
        length = np.linalg.norm(self.x[rig.vert_a] - self.x[rig.vert_b], axis=1)
        k = int(np.argmin(length)) if len(length) else -1
        if k < 0 or not length[k] < 1e-9 * rig.vert_rest[k]:
            return ''
        row, col = divmod(int(rig.vert_b[k]), rig.cols)
        return f': the vertical edge above row {row}, column {col} has no length'

    def _lying_down(self, sample: Sample) -> list[str]:
        """Say that the body lies down at the first input, if it does; gravity stays the world's.

        The body's up is the root link to the hood's link (rig.body_tilt), as the input poses
        them. Further than rig.UP_TOLERANCE_DEG from the world's up, a capture that starts on
        the floor (or a Y-up URDF whose world joint does not stand it up) lies down: one line
        says so, and gravity and the floor keep the world's up (issue 47 item 1: turning them
        onto the body tilted a get-up clip's floor by 67-82 degrees).
        """
        rig = self.rig
        tilt = rig.body_tilt(self.skeleton.forward(sample.q), sample.root[:3, :3])
        if tilt is None:
            return []
        body_up, angle = tilt
        names = self.skeleton.link_names
        return [f'the body lies {angle:.0f} deg from the world\'s up {_shown(rig.world_up)} at '
                f'the first input ({names[0]} to {names[rig.hood.link]}: {_shown(body_up)}); '
                'gravity and the floor stay the world\'s: if this world\'s up is another axis, '
                'write world_up in the rig']

    def lying_without_world_pose(self) -> str:
        """Say that the body lies down where no world pose stands it, or ''.

        Sent without ``world_joint/*``, the root stands the zero pose on the floor as the URDF
        draws it: a body that then lies (a Y-up URDF) lies because of the set-up, not the
        motion, for as long as it lasts (a capture lying on the floor is said once, at the
        first input).
        """
        if not self.parser.guessed or self.last is None:
            return ''
        tilt = self.rig.body_tilt(self.links, self.root[:3, :3])
        if tilt is None:
            return ''
        return (f'the body lies {tilt[1]:.0f} deg from the world\'s up '
                f'{_shown(self.rig.world_up)}, stood on its zero pose with no world pose: send '
                f'{self.parser.world_joint}/* to stand it up, or turn the URDF\'s root')

    def _inside_at_rest(self) -> list[str]:
        """Say where the rest cloth is inside the rig's colliders at the zero pose, if it is."""
        rig, worst = self.rig, deepest_at_rest(self.rig)
        if worst.value <= INSIDE_AT_REST:
            return []
        row, col = divmod(worst.vertex, rig.cols)
        return [f'the cloth starts inside the body: row {row}, column {col} is '
                f'{worst.value * 1e3:.0f} mm inside collider {worst.collider!r} at the zero '
                'pose; widen cloth.shape.radii (or move cloth.shape.center) or shrink that '
                'collider']

    def _stretched_at_start(self, inside: bool) -> list[str]:
        """Say where the cloth, just put on the first input's skinned pose, is stretched.

        The key to change: the cloth's shape if it starts inside the colliders (they push it
        out wider), else the M2 skinning's reach where the top row follows the pads.

        :param inside: whether the cloth starts inside the colliders (said at load).
        """
        rig, out = self.rig, []
        vs, _, hs, _ = self.edge_strains()
        for worst, across in ((hs, True), (vs, False)):
            if not worst.value > STRETCHED_AT_START:
                continue
            row, col = divmod(worst.vertex, rig.cols)
            layer = rig.layer
            if not inside and layer is not None and layer.pads and rig.pin_weight[col] > 0:
                fix = f'lower jacket_bones.upper.skin_radius ({layer.skin_radius:g})'
            else:
                fix = 'fit cloth.shape.radii and center to the colliders'
            out.append(f'the cloth starts stretched {worst.value:.0%} '
                       f'{"across" if across else "down"} at row {row}, column {col} on the '
                       f'first input: {fix}')
        return out

    def _collapsed(self, sample: Sample) -> str:
        """Say that the cloth has stayed bunched or stretched across, and the rig key to change.

        A body lying down bunches the cloth along it: the world's up. Stretched across: the
        colliders hold it wider than its rest (the shape's radii). Bunched on a standing body:
        a cloth narrower than the body in places (a hem drawn in by the flare), which the
        colliders push out there and which folds between; a shorter reach at the hem (M11)
        folds it more, not less.
        """
        rig, watch = self.rig, self.watches.collapse
        row, stretched = watch.worst_row(rig.cols)
        tilt = rig.body_tilt(self.links, sample.root[:3, :3])
        if tilt is not None:
            fix = (f'the body lies {tilt[1]:.0f} deg from the world\'s up '
                   f'{_shown(rig.world_up)}: write world_up in the rig if this world\'s up is '
                   'another axis, else stand the body up (motion --urdf retargets a clip)')
        elif sunk := self._under_floor():
            fix = sunk
        elif stretched:
            fix = 'widen cloth.shape.radii: the colliders hold it wider than its rest'
        else:
            fix = ('fit cloth.shape (radii, flare, center) to the colliders: the body pushes a '
                   'cloth narrower than itself out in places and it folds between')
        since = (watch.since_ns - (watch.first_ns or watch.since_ns)) * 1e-9
        kind = 'stretched' if stretched else 'bunched'
        return (f'the cloth is {kind} across from {since:.1f} s on: its horizontal edges\' '
                f'p99 strain {watch.p99:.0%} for over {COLLAPSED_FOR_S:g} s (most at row {row}); '
                f'{fix}')

    def time_stages(self, timer: StageTimer) -> None:
        """Run this simulation's stages through a profiler's ``timer`` from now on.

        ``prepare``, ``step`` (the compiled steps and bones, physics.crowd.advance_slot, with
        a steady input's intake before them), ``complete`` and ``bones`` are each replaced, on
        this simulation only, by what ``timer(name, stage)`` returns. A simulation never given
        a timer calls its stages directly, as before.

        :param timer: called once per stage with its name and callable; returns the callable
            to run in its place (e.g. one that adds the stage's CPU time to a clock).
        """
        self.prepare = timer('prepare', self.prepare)
        self.steps.advance = timer('step', self.steps.advance)
        self.steps.steady = timer('step', self.steps.steady)
        self.complete = timer('complete', self.complete)
        self.bones = timer('bones', self.bones)

    # -- one input ----------------------------------------------------------------------------
    def process(self, stamp_ns: int, names: Sequence[str],
                positions: npt.ArrayLike) -> StepReport:
        """Advance the simulation to ``stamp_ns`` with one JointState's content.

        An accepted input's bones are checked (:meth:`check_bones`): :meth:`bones` then gives
        them, finite unless the skeleton's pose is degenerate.

        :param stamp_ns: the JointState's header stamp, ns.
        :param names: its joint names.
        :param positions: its positions, one per name (rad or m).
        """
        started = time.perf_counter_ns()
        status = self.steps.take(self.steady_key(names), stamp_ns, positions)
        if status != NOT_STEADY:
            return self.took_steady(stamp_ns, names, status, started)
        report, job = self.prepare(stamp_ns, names, positions)
        if job is not None:
            self.finish(report, job, self.steps.run(job))
        return self._checked(report, names, started)

    def took_steady(self, stamp_ns: int, names: Sequence[str], status: int,
                    started: int) -> StepReport:
        """Finish an input the compiled intake took and stepped, as :meth:`process` does.

        For a caller that ran the intake itself (``steps.steady``, or ros/steady_lane.py from
        a JointState's bytes): the input's report, its bones checked.

        :param stamp_ns: the input's stamp, ns.
        :param names: its joint names (the armed ones).
        :param status: what the compiled call returned (not NOT_STEADY).
        :param started: ``time.perf_counter_ns()`` before that call, for the step cost.
        """
        report = self._took_again(stamp_ns, status, started)
        if report is not None:
            if report.warnings:         # a watch spoke: the intake disarms, as settle would
                self.steps.armed = self._own = None
            return report
        report, job = self.steady_job(stamp_ns)
        self.finish(report, job, status)
        report = self._checked(report, names, started)
        # Made here and held by no caller: the next steady input may move them on in place.
        self._own = (self.last, self.parser.last, self.ready_bones) \
            if self.steps.armed is not None else None
        return report

    def _took_again(self, stamp_ns, status, started):
        """took_steady of a steady input after one: its bookkeeping in place; else None.

        The last sample (the parser's too) and the bones the last steady input left are this
        simulation's own: they take this input's values in place, so the intake stays armed
        for the same objects and nothing is made anew; the watches look as :meth:`complete`
        has them look. Anything else goes the whole way: bones or a cloth not finite, those
        objects replaced (a reset, a Python input, a caller that dropped the bones).
        """
        own, steps = self._own, self.steps
        if (own is None or status != BONES_FINITE or own[0] is not self.last
                or own[1] is not self.parser.last or own[1].q is not own[0].q
                or own[2] is not self.ready_bones):
            return None
        slot = steps.slot
        deepest, limited, sweeps, substeps, non_finite, hem_path, retried = \
            slot.out.stats.tolist()
        if non_finite:
            return None
        last = own[0]
        last.stamp_ns = stamp_ns
        last.q[:] = slot.q_b
        last.root[:] = steps.intake.last.root
        last.root_quat[:] = slot.quat_b
        own[2].poses[:] = slot.bones
        steps.steady_inputs += 1
        _, _, t_sim, _, n = slot.clock.tolist()
        self.t_sim = t_sim
        self.steps_total += n
        self.faults.retried += int(retried)
        report = StepReport(stamp_ns, steps=n, max_penetration=max(0.0, deepest),
                            limited_vertices=int(limited), sweeps=int(sweeps),
                            substeps=int(substeps), retried_steps=int(retried))
        self._watch(report, last, hem_path)
        report.step_cost_ns = time.perf_counter_ns() - started
        return report

    def _checked(self, report, names, started):
        """End an input: its cost, its bones checked, the intake armed or not."""
        report.step_cost_ns = time.perf_counter_ns() - started
        if report.accepted:
            self.check_bones(report)
        self.settle(names, report)
        return report

    def steady_key(self, names: Sequence[str]) -> tuple:
        """Return what an input with ``names`` comes on, for the compiled intake.

        (names, tuning, world_joint, last sample): Stepper.ready_for takes the input only for
        the very objects it was armed for; with a viewer, the last sample is left out, so that
        nothing matches.

        :param names: the input's joint names.
        """
        return (names, self.tuning, self.parser.world_joint,
                self.last if self.lod.viewer is None else None)

    def settle(self, names: Sequence[str], report: StepReport) -> None:
        """After an input: arm the compiled intake if the next input may be steady.

        It may if prepare would take it on from here as physics.crowd.steady_input does: this
        input was stepped without a warning, reset or skipped step, at full detail with no
        viewer, and its name list is a tuple (a list could change under the same object).

        :param names: the input's joint name list.
        :param report: the input's step report.
        """
        lod, steps = self.lod, self.steps
        if (not isinstance(names, tuple) or not report.accepted or report.reset
                or report.steps <= 0 or report.skipped_steps or report.warnings
                or lod.viewer is not None or lod.level or lod.skin
                or steps.slot.tuning is not self.tuning):
            steps.armed = None
            return
        key = self.steady_key(names)
        if not steps.rearm(key):
            plan = self.parser.plan(names)[0]
            if len(plan.joint_from) + len(plan.world_from) != len(names):
                steps.armed = None      # names it skips (mimic joints): the intake takes none
                return
            p = self.params
            steps.arm(key, plan, self.last,
                      (self.dt_ns, p.max_steps_per_input),
                      (p.reset_gap, self.teleport_m, p.teleport_angle_deg))

    def steady_job(self, stamp_ns: int) -> tuple[StepReport, 'StepJob']:
        """Return the report and job prepare would have made of an input the intake loaded.

        :param stamp_ns: the input's stamp, ns.
        """
        self.ready_bones = None             # as prepare drops them: the state moved on
        sample = self.steps.taken(stamp_ns)
        self.parser.last = JointSample(sample.q, sample.root, sample.root_quat)
        clock = self.steps.slot.clock
        return StepReport(stamp_ns), StepJob(sample, int(clock[4]), self.last, self.t_sim,
                                             self.dt_ns, self.tuning)

    def finish(self, report: StepReport, job: 'StepJob', status: int) -> None:
        """Take a job's steps and bones as the compiled call left them in the slot.

        :param report: the input's report.
        :param job: the steps run.
        :param status: what the call returned (physics.crowd's STEPS_FAILED, BONES_FINITE or
            BONES_NOT_FINITE).
        """
        slot = self.steps.slot
        self.t_sim = int(slot.clock[2])
        self.complete(report, job, slot.out, status != STEPS_FAILED)
        if not report.reset:        # the bones the call made are the state's
            self.ready_bones = Bones(self.bone_names, self.bone_parents, slot.bones.copy(),
                                     status == BONES_FINITE)

    def prepare(self, stamp_ns: int, names: Sequence[str],
                positions: npt.ArrayLike) -> tuple[StepReport, 'StepJob | None']:
        """Do an input's work before its compiled steps; return the report and the steps to run.

        No steps (a refused input, a reset, no step due): the input is done and the job None.
        Else run the job (``steps.run``, or a crowd's round) and hand the outcome to
        :meth:`finish`.

        :param stamp_ns: the JointState's header stamp, ns.
        :param names: its joint names.
        :param positions: its positions, one per name (rad or m).
        """
        report = StepReport(stamp_ns)
        self.ready_bones = None
        try:
            if self._another_source(stamp_ns, names):
                self._merge(self.parser.parse(stamp_ns, names, positions), report)
                return report, None
            self._check_stamp(stamp_ns, report)
            sample = self.parser.parse(stamp_ns, names, positions)
        except InputRejected as e:
            report.accepted = False
            report.reset = ''           # a stamp gap marked it, but nothing is reset
            report.warnings.append((e.code, str(e)))
            return report, None
        report.warnings += sample.warnings
        if not report.reset and self.last is None:
            report.reset = 'first sample'
        elif not report.reset:
            report.reset = self._restart_reason(self.last, sample)
        if report.reset:
            first = report.reset == 'first sample'
            if first:
                self.watches.collapse.first_ns = sample.stamp_ns
            at_load = len(self.faults.rig)      # said at load (the node logs them then)
            if first:
                self.faults.rig += self._lying_down(sample)
            self._reset(sample)
            if not (np.isfinite(self.x).all() and np.isfinite(self.hood_p).all()):
                report.reset = 'non-finite cloth state'
                self._reset(sample)
            if first:
                self.faults.rig += self._stretched_at_start(inside=bool(self._inside))
                # A code each: the node logs one line per code at most every few seconds.
                report.warnings += [(f'rig{k}', w) for k, w in
                                    enumerate(self.faults.rig[at_load:], at_load)]
            return report, None
        a = self.last
        n = (sample.stamp_ns - self.t_sim) // self.dt_ns
        cap = self.params.max_steps_per_input
        if n > cap:
            report.skipped_steps = n - cap
            self.faults.overruns += 1
            self.t_sim += (n - cap) * self.dt_ns
            n = cap
        if n <= 0:
            report.steps = n
            self.steps_total += n
            self.last = sample
            return report, None
        plan = self.lod.plan(sample.root[:3, 3], self.params.lod_distances,
                             self.params.lod_blend_s, n, self.dt_ns * 1e-9)
        report.lod_level = plan.level
        return report, StepJob(sample, int(n), a, int(self.t_sim), int(self.dt_ns),
                               self.lod.tuned(self.tuning, plan))

    def complete(self, report: StepReport, job: 'StepJob', out: StepOutput, ran: bool) -> None:
        """Take a job's steps into the simulation; a non-finite cloth is reset.

        :param report: the input's report, from :meth:`prepare`.
        :param job: the steps run.
        :param out: what the steps left.
        :param ran: False if they stopped on a division by zero.
        """
        finite = ran
        if ran:
            self._take_output(out)
            stats = out.stats
            report.max_penetration = max(report.max_penetration, stats[step.DEEPEST])
            report.limited_vertices += int(stats[step.LIMITED])
            report.sweeps += int(stats[step.SWEEPS])
            report.substeps += int(stats[step.SUBSTEPS])
            retried = int(stats[step.RETRIED])
            report.retried_steps += retried
            self.faults.retried += retried
            report.steps = job.steps
            self.steps_total += job.steps
            self.last = job.sample
            finite = not stats[step.NON_FINITE]
        if not finite:
            report.reset = 'non-finite cloth state'
            self._reset(job.sample)
        else:
            self._watch(report, job.sample, float(out.stats[step.HEM_PATH]))

    def _watch(self, report, sample, hem_path):
        """Let the watches see the cloth after an input's steps; a finding goes in the report.

        :param hem_path: the hem's mean path over the input's steps (step.HEM_PATH), m.
        """
        watches, stamp_ns = self.watches, sample.stamp_ns
        if watches.collapse.note(self.x, stamp_ns):
            line = self._collapsed(sample)
            self.faults.collapse.append(line)
            report.warnings.append(('collapse', line))
        if not self._windy() and watches.restless.note(hem_path, self.links, self.root,
                                                       stamp_ns):
            line = self._restless()
            self.faults.restless.append(line)
            report.warnings.append(('restless', line))
        line = watches.floor.note(self._under_floor, stamp_ns)
        if line:
            self.faults.under_floor.append(line)
            report.warnings.append(('under_floor', line))

    def _windy(self):
        """Tell whether wind moves the cloth: then a cloth moving on a still body is right."""
        p = self.params
        return p.wind_gust > 0.0 or any(p.wind)

    def _restless(self) -> str:
        """Say that the cloth keeps moving on a still body, and the setting that rests it."""
        watch = self.watches.restless
        f = self.fabric
        if f.edge_damping < f.damping:
            setting = (f'fabric.edge_damping ({f.edge_damping:g} now, the rest {f.damping:g}): '
                       'its free edges, damped least,')
        else:
            setting = (f'fabric.damping and fabric.edge_damping ({f.damping:g} and '
                       f'{f.edge_damping:g} now): it')
        said = (f'the cloth keeps moving with the body still: its hem at '
                f'{100 * watch.speed:.1f} cm/s after {RESTLESS_FOR_S:g} s still; ')
        sunk = self._under_floor()
        if sunk:
            return said + sunk
        return (said + f'raise {setting} keep swinging where the vertical pass fights the body '
                'and the floor')

    def _under_floor(self) -> str:
        """Say that the body reaches under the rig's floor, and what puts it there; or ''.

        The floor then holds the cloth against the legs, which no fabric or shape setting
        mends: the cause is the pose (a source's world pose, a capture not stood on its soles).
        """
        floor = self.rig.floor()
        if floor is None:
            return ''
        up, height = floor
        # The links are in the root's frame: the world's up turned into it.
        low = lowest_reach(self.skeleton, self.links, self.root[:3, :3].T @ up) + float(
            self.root[:3, 3] @ up)
        if height - low <= UNDER_FLOOR_PER_HEIGHT * self.rig.height_m:
            return ''
        return (f'the body reaches {height - low:.2f} m under the rig\'s floor, which holds the '
                'cloth against it: raise the root\'s world pose (world_joint/trans_*), stand a '
                'capture on its soles (motion --urdf) or lower the floor in the rig')

    def _another_source(self, stamp_ns, names):
        """Tell whether an input is a second source's: another name list, not ahead in time.

        Two publishers on one topic (a robot's legs and arms, a gripper beside its arm), each
        stamped by the same control tick or a little behind: robot_state_publisher merges
        them by name, and so does this simulation, rather than drop every other input.
        """
        last = self.last
        if last is None or self.parser.names is None or tuple(names) == self.parser.names:
            return False
        gap = (stamp_ns - last.stamp_ns) * 1e-9
        return -self.params.reset_gap < gap <= 0

    def _merge(self, sample, report):
        """Take a second source's values into the last pose, which the next steps start from.

        No step and nothing to publish: its stamp is the last one's, or behind it.
        """
        last = self.last
        merged = Sample(last.stamp_ns, sample.q, sample.root, sample.root_quat,
                        world_began=sample.world_began)
        report.merged = True
        report.warnings += sample.warnings
        # As prepare judges any input: its world pose may teleport or begin off the guess.
        report.reset = self._restart_reason(last, merged)
        if report.reset:
            self._reset(merged)
        else:
            self.last = merged

    def _check_stamp(self, stamp_ns, report):
        if self.last is None:
            return
        gap = (stamp_ns - self.last.stamp_ns) * 1e-9
        if gap == 0:
            if stamp_ns == 0:       # a driver that leaves header.stamp unset
                raise InputRejected('stamp', 'repeated stamp 0 (header.stamp not set by the '
                                    'publisher; the steps run on the stamps): message dropped')
            raise InputRejected('stamp', 'repeated stamp: message dropped')
        if gap < 0:
            if -gap > self.params.reset_gap:
                report.reset = f'stamps jumped back {-gap:.2f} s (source restarted)'
                return
            raise InputRejected('stamp', f'stamp went back {-gap * 1e3:.1f} ms: message dropped')
        if gap > self.params.reset_gap:
            report.reset = f'gap of {gap:.2f} s between stamps'

    @property
    def teleport_m(self) -> float:
        """The world move between two inputs (m) treated as a teleport: set, or from the height."""
        return self.params.teleport_distance or AUTO_TELEPORT_PER_HEIGHT * self.rig.height_m

    def _restart_reason(self, a, b):
        """Why the cloth restarts from sample a to b, or '': a teleport, a world pose begun."""
        return self._jump(a, b) or (
            WORLD_BEGAN if b.world_began and self._off_the_guess(a, b) else '')

    def _jump(self, a, b):
        """Why the world move from sample a to b is too big to simulate through, or ''."""
        move, turn = root_jump(a.root, b.root, a.root_quat, b.root_quat)
        if move > self.teleport_m:
            if not np.isfinite(move):       # its square overflowed: math.dist scales
                move = math.dist(a.root[:3, 3], b.root[:3, 3])
            shown = f'{move:.2f}' if move < 1e6 else f'{move:.3g}'
            return f'teleport: moved {shown} m between two inputs'
        if turn > self.params.teleport_angle_deg:
            return f'fast turn: turned {turn:.0f} deg between two inputs'
        return ''

    def _off_the_guess(self, a, b):
        """Tell whether the first world pose, b, is off the guessed root of a: then a restart.

        A guess that was right (a source standing its robot where the rig's floor stands it)
        keeps its swinging cloth: a restart would show as a pop.
        """
        move, turn = root_jump(a.root, b.root, a.root_quat, b.root_quat)
        return not (move <= GUESS_KEPT_PER_HEIGHT * self.rig.height_m
                    and turn <= GUESS_KEPT_DEG)

    def step_output(self) -> StepOutput:
        """Return new arrays for what step.advance leaves (the last step's pose, stats)."""
        layer = self.rig.layer
        k = len(layer.names) if layer else 0
        return StepOutput(np.empty(self.links.shape), np.empty((k, 3, 3)), np.empty((k, 3)),
                          np.empty((k, 3)), np.empty((len(layer.pads) if layer else 0, 4, 4)),
                          np.zeros(step.STAT_SLOTS),
                          np.full(len(layer.sleeves) if layer else 0, np.nan))

    def _take_output(self, out):
        """Take the last step's pose and layer bones as the steps left them in ``out``."""
        layer = self.rig.layer
        self.links = out.links
        self._layer = (out.links, LayerPose(layer.names, layer.parent_index, out.layer_rot,
                                            out.layer_pos, out.layer_tips, out.below)
                       if layer else None)

    def set_viewer(self, position: npt.ArrayLike | None) -> None:
        """Set the viewer's world position for the level of detail (None: full detail).

        An input like a JointState: from the next one on, until set again.

        :param position: the viewer, (3,) in the world frame, m; None: full detail.
        """
        self.lod.set_viewer(position)

    def _run_steps(self, a, b, n):
        """Run ``n`` fixed steps from sample ``a`` towards ``b`` in the compiled call.

        The skeleton is interpolated at each step (M7), then M14, M1/M2, M6/M11, M10, the cloth
        and M8 (see step.advance). Returns its stats.
        """
        self.steps.run(StepJob(b, n, a, self.t_sim, self.dt_ns, self.tuning))
        out = self.steps.slot.out
        self.t_sim = int(self.steps.slot.clock[2])
        self._take_output(out)
        return out.stats

    def _cloth_step(self, links, root, ref, acc, damping, contact_damping, dt):
        """Run one kernel step of the current state at this skeleton pose, no substeps.

        The reset's settling step; its colliders and references are where the next step's
        substeps start from.
        """
        args = self.kernel_arguments(links, root, ref, acc, damping, contact_damping, dt)
        out = cloth.cloth_step(*args)
        for kept, now in zip(self._before, args[-1]):
            kept[:] = now
        self.state.started[0] = True
        return out

    def kernel_arguments(self, links: np.ndarray | None = None, root: np.ndarray | None = None,
                         ref: np.ndarray | None = None, acc: np.ndarray | None = None,
                         damping: npt.ArrayLike | None = None,
                         contact_damping: float | None = None, dt: float | None = None) -> tuple:
        """Return cloth.cloth_step's bundles for one step of the current state, no substeps.

        By default at the current pose with the fabric's forces; the lab times the kernel on them.

        :param links: the link transforms (L, 4, 4) in the simulation frame; None: the current.
        :param root: the root's world pose (4, 4); None: the current.
        :param ref: the M11 reference points (N, 3); None: those of ``links``.
        :param acc: each vertex's acceleration (N, 3), m/s^2 in the simulation frame; None:
            gravity and wind.
        :param damping: each vertex's share of velocity lost per step; None: the fabric's.
        :param contact_damping: the share lost per step in contact; None: the fabric's.
        :param dt: the step's length, s; None: the simulation's.
        """
        p, f = self.params, self.fabric
        links = self.links if links is None else links
        root = self.root if root is None else root
        if ref is None:
            ref = self.reference_points(links, self.layer if links is self.links else None)
        if acc is None:
            world_to_local = root[:3, :3].T
            acc = (world_to_local @ (-p.gravity * self.model.cloth.up)
                   + self.tuning.wind_scale[:, None]
                   * (world_to_local @ p.wind_at(self.t_sim or 0)))
        e = DESIGN_RATE / p.sim_rate
        damping = per_step(self.tuning.damping, e) if damping is None else damping
        if contact_damping is None:
            contact_damping = per_step(f.contact_damping, e)
        dt = self.dt_ns * 1e-9 if dt is None else dt
        now = self._posed(links, root, ref)
        control = StepControl(floats(acc), floats(damping), float(contact_damping), float(dt),
                              1, self.x)
        return (self.model.cloth, self.model.colliders, self.tuning, self.state, control, now,
                now)

    def hood_step(self, links: np.ndarray, acc: np.ndarray, dt: float, damping: float) -> None:
        """M8: one Verlet particle on a rod of fixed length from the hood bone's centre.

        It rests on the rig's planes (the floor) where the rod reaches them.

        :param links: the link transforms (L, 4, 4) in the simulation frame.
        :param acc: the particle's acceleration (3,), m/s^2 in the simulation frame.
        :param dt: the step's length, s.
        :param damping: the share of velocity lost in the step.
        """
        now = self._posed(links, self.root)
        hood.hood_step(links, self.model.cloth, self.hood_p, self.hood_pp, floats(acc),
                       float(dt), float(damping), now.plane_p, now.plane_n)

    def _posed(self, links, root, ref=None):
        """Colliders (and M11 references, zero if not given) in the simulation frame."""
        now = posed_like(self.model.colliders, self.rig.n)
        colliders.collider_poses(links, self.model.colliders, now)
        colliders.plane_poses(links, root, self.model.colliders, now)
        if ref is not None:
            now.ref[:] = ref
        return now

    def collider_frames(self, links: np.ndarray, root: np.ndarray | None = None) -> Colliders:
        """Every collider in the simulation frame, for the kernel and the markers.

        :param links: the link transforms (L, 4, 4) in the simulation frame.
        :param root: the root's world pose (4, 4), for the planes fixed in the world (the
            floor); None: the current.
        """
        c = self._posed(links, self.root if root is None else root)
        return Colliders(c.centers, c.axes, floats(self.rig.collider_radii), c.cap_a, c.cap_b,
                         floats(self.rig.capsule_radii), c.plane_p, c.plane_n)

    # -- outputs ------------------------------------------------------------------------------
    def bones(self) -> Bones:
        """Return the M9 jacket bones and the M8 hood bone.

        Jacket bones have x down the cloth, y left to right and z = x * y. After an input they
        are that input's checked bones (``ready_bones``) until the next input or reset; a
        caller that moves the cloth by hand in between drops them (``ready_bones = None``).
        """
        if self.ready_bones is not None:
            return self.ready_bones
        layer = self.layer
        layer = _NO_LAYER_POSE if layer is None else layer
        # Into the slot's poses, as the compiled call makes them: a grid bone whose edges all
        # lie flat keeps the rotation it had there (pose.kept_bone_poses).
        poses = self.steps.slot.bones
        finite = pose.kept_bone_poses(self.x, self.hood_p, self.links, self.model.cloth,
                                      self.bone_set.grid, layer.parents, layer.rotations,
                                      layer.positions, poses)
        return Bones(self.bone_names, self.bone_parents, poses.copy(), finite)

    def strain(self) -> tuple[float, float]:
        """Worst |length / rest - 1| of the vertical and horizontal stretch constraints."""
        vs, vc, hs, hc = self.edge_strains()
        return max(vs.value, vc.value), max(hs.value, hc.value)

    def edge_strains(self) -> tuple:
        """(stretch, compression) of the verticals, then of the horizontals, with where.

        The pinned top row (M6) is skinned, not simulated, so its own lengths are left out.
        """
        rig, c = self.rig, self.model.cloth      # its horizontals: those with a free end
        return (*edge_strain(self.x, rig.vert_a, rig.vert_b, rig.vert_rest),
                *edge_strain(self.x, c.horiz_a, c.horiz_b, c.horiz_rest))


def _shown(v: np.ndarray) -> str:
    """Write a direction as a rig writes it: [x, y, z], rounded."""
    return '[' + ', '.join(f'{round(float(x), 3) + 0.0:g}' for x in v) + ']'


def _put(kept: np.ndarray, value: npt.ArrayLike) -> None:
    """Write ``value`` into a state array in place: the state is held once, never replaced."""
    kept[...] = value


def bone_set(skeleton: 'Skeleton', rig: 'Rig') -> BoneSet:
    """Return every bone of ``rig``: M9 cloth bones, M8 hood bone, M1/M2 layer bones.

    :param skeleton: the character.
    :param rig: its rig.
    """
    grid = np.array(rig.bone_vertices(), dtype=np.int64).reshape(-1, 2)
    layer_parents = [skeleton.link_names[k] for k in rig.layer.parents] if rig.layer else []
    root = skeleton.link_names[0]
    return BoneSet(rig.bone_names(), [root] * len(grid) + [skeleton.link_names[rig.hood.link]]
                   + layer_parents, grid)
