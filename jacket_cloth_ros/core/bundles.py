# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The named bundles of arrays that the compiled steps take, each built in one place.

As NVIDIA Warp's sim passes ``model, state, control``, the kernels take a few named tuples
instead of long positional lists, so two neighbouring arrays of one dtype and shape can no
longer be swapped by a caller:

- :class:`Model`: what never changes while a character runs (skeleton, M1/M2 layer, cloth
  topology and pins, colliders in their links' frames), built by :func:`model_of`;
- :class:`Tuning`: the fabric's and the parameters' values, rebuilt on a live change
  (:func:`tuning_of`);
- :class:`ClothState`: cloth, hood and root, moved in place by the steps;
- :class:`Posed`: colliders and M11 references in the simulation frame at one instant;
- :class:`Motion` and :class:`StepControl`: what drives one input's steps or one cloth step;
- :class:`StepOutput`: what the steps leave for the bones and the report;
- :class:`CrowdSlot`: one character of a crowd, for the crowd's one compiled call, and
  :class:`SteadyIntake`, the compiled check of its steady inputs.

Every builder fixes each field's dtype and memory layout, so the compiled code sees the same
types on every call (see kernel_cache.FixedTypes). This file is a kernel file: the compiled
code depends on the fields' order, so an edit here recompiles every kernel.
"""

from typing import TYPE_CHECKING, NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:           # for the annotations only: these modules build on this one
    from .bone_layer import BoneLayer
    from .rig import Rig
    from .skeleton import Skeleton

_Bundle = TypeVar('_Bundle')


def floats(a: npt.ArrayLike) -> np.ndarray:
    """Return ``a`` as a C-contiguous float64 array (the kernels' float type)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def ints(a: npt.ArrayLike) -> np.ndarray:
    """Return ``a`` as a C-contiguous int64 array (the kernels' index type)."""
    return np.ascontiguousarray(a, dtype=np.int64)


def flags(a: npt.ArrayLike) -> np.ndarray:
    """Return ``a`` as a C-contiguous boolean array."""
    return np.ascontiguousarray(a, dtype=np.bool_)


class SkeletonModel(NamedTuple):
    """The skeleton for forward kinematics (links in breadth-first order, see Skeleton)."""

    origin: np.ndarray      # (L,4,4) joint origin in the parent link's frame
    axis: np.ndarray        # (L,3) joint axis
    kind: np.ndarray        # (L,) pose_kernel.FIXED, ROTATION or TRANSLATION
    var: np.ndarray         # (L,) index of the joint variable, -1 for none
    mult: np.ndarray        # (L,) mimic multiplier
    offset: np.ndarray      # (L,) mimic offset
    parent: np.ndarray      # (L,) parent link index


class LayerModel(NamedTuple):
    """M1 sleeves and M2 shoulder pads (see bone_layer.BoneLayer); empty without a layer."""

    sleeve_link: np.ndarray
    sleeve_end: np.ndarray
    sleeve_axis: np.ndarray
    sleeve_length: np.ndarray
    sleeve_share: np.ndarray
    sleeve_rest: np.ndarray  # (S,3,3) the end link's rest rotation in the link's frame, inverse
    upper: int              # the torso link the pads sit on
    pad_pivot: np.ndarray
    pad_aim_link: np.ndarray
    pad_aim: np.ndarray
    pad_length: np.ndarray
    pad_below_length: np.ndarray
    down: np.ndarray        # (3,3) a bone aimed straight down in the torso frame
    side: np.ndarray        # (3,) the body's left in the torso frame: the pads' y
    rest_gap: float         # M2 left/right distance of the pad ends at rest


class ClothModel(NamedTuple):
    """The cloth grid's topology, its pins (M6), references (M11) and the hood (M8)."""

    pin_link: int
    pin_local: np.ndarray           # (C,3) top row in the pin link's frame
    reference_link: np.ndarray      # (N,) M11 reference bone per vertex
    reference_local: np.ndarray     # (N,3)
    pin_below: np.ndarray           # (C,) M2 bone below a pad that carries each top vertex
    pin_below_local: np.ndarray     # (C,3)
    pin_weight: np.ndarray          # (C,) share carried by that bone
    free: np.ndarray                # (N,) bool: simulated, not pinned
    con_a: np.ndarray               # M5 constraints: ends and rest lengths
    con_b: np.ndarray
    con_rest: np.ndarray
    vert_a: np.ndarray              # M12 vertical edges, top to bottom
    vert_b: np.ndarray
    vert_rest: np.ndarray
    horiz_a: np.ndarray             # horizontal edges with a free end, held by the strain limit
    horiz_b: np.ndarray
    horiz_rest: np.ndarray
    row_a: np.ndarray               # the pinned top row's own horizontal edges (C-1,)
    row_rest: np.ndarray
    tether_anchor: np.ndarray       # long-range attachments: pinned anchor and length
    tether_length: np.ndarray
    hood_link: int
    hood_pivot: np.ndarray          # (3,) the hood bone's centre in its link's frame
    hood_length: float
    hood_side: np.ndarray           # (3,) the body's left in the hood link's frame: its y
    up: np.ndarray                  # (3,) world: gravity pulls along -up


class ColliderModel(NamedTuple):
    """Colliders in their links' frames (M10 ellipsoids, capsules, planes)."""

    links: np.ndarray
    centers: np.ndarray
    rotations: np.ndarray
    radii: np.ndarray
    capsule_links: np.ndarray
    capsule_ends: np.ndarray
    capsule_radii: np.ndarray
    plane_links: np.ndarray         # -1: fixed in the world (the floor)
    plane_points: np.ndarray
    plane_normals: np.ndarray


class Model(NamedTuple):
    """Everything about a character that stays fixed while it runs."""

    skeleton: SkeletonModel
    layer: LayerModel
    cloth: ClothModel
    colliders: ColliderModel


class Tuning(NamedTuple):
    """The fabric's and the simulation parameters' values (live changes rebuild it)."""

    stiffness: np.ndarray           # M5 per constraint, per sweep
    iterations: int
    compliance: np.ndarray          # XPBD, per constraint
    max_distance: np.ndarray        # M11 per vertex
    limit_mode: int                 # kernel.LIMIT_*
    horizontal_limit: float         # most stretch of a horizontal edge over its rest length
    solver: int                     # kernel.SOLVER_*
    max_substeps: int
    quality_tolerance: float        # m; > 0: automatic substeps
    sweep_tolerance: float          # m; > 0: relaxation stops early
    damping: np.ndarray             # M4/M13 per vertex, per design step
    contact_damping: float          # M15
    hood_damping: float
    design_exponent: float          # DESIGN_RATE / sim_rate
    world_share: np.ndarray         # M14 per vertex
    hood_world_share: float
    wind_scale: np.ndarray          # per vertex
    hood_wind_scale: float
    gravity: float
    wind: np.ndarray                # (3,) world frame
    gust: float
    gust_period: float
    # Level of detail (core/lod.py): share of the skinned pose at the start and end of one
    # input's steps; 1 at both: no cloth step runs.
    skin_from: float = 0.0
    skin_to: float = 0.0


class ClothState(NamedTuple):
    """What the steps move in place."""

    x: np.ndarray                   # (N,3) cloth, simulation frame
    xp: np.ndarray                  # (N,3) previous positions (Verlet)
    contact: np.ndarray             # (N,) bool, M15
    hood_p: np.ndarray              # (3,) hood particle and its previous position
    hood_pp: np.ndarray
    root: np.ndarray                # (4,4) the root's world pose
    lam: np.ndarray                 # XPBD multipliers per constraint
    started: np.ndarray             # (1,) bool: a step ran, so ``before`` holds its end


class Posed(NamedTuple):
    """Colliders and M11 references in the simulation frame at one instant."""

    centers: np.ndarray
    axes: np.ndarray
    cap_a: np.ndarray
    cap_b: np.ndarray
    plane_p: np.ndarray
    plane_n: np.ndarray
    ref: np.ndarray


class Motion(NamedTuple):
    """One input's steps: the skeleton samples a and b, and the step clock."""

    q_a: np.ndarray
    q_b: np.ndarray
    quat_a: np.ndarray
    quat_b: np.ndarray
    pos_a: np.ndarray
    pos_b: np.ndarray
    stamp_a: int                    # ns
    span: int                       # ns from a to b
    t_sim: int                      # ns of the last step run
    dt_ns: int
    steps: int


class StepControl(NamedTuple):
    """What drives one cloth step (kernel.cloth_step)."""

    acc: np.ndarray                 # (N,3) gravity and wind, simulation frame
    damping: np.ndarray             # (N,) per substep
    contact_damping: float          # per substep
    dt: float                       # s
    substeps: int
    pin_from: np.ndarray            # (N,3) pinned vertices at the step's start


class StepOutput(NamedTuple):
    """What advance leaves: the last step's pose, its layer bones, and the stats."""

    links: np.ndarray
    layer_rot: np.ndarray
    layer_pos: np.ndarray
    layer_tips: np.ndarray
    below: np.ndarray
    stats: np.ndarray


class SteadyIntake(NamedTuple):
    """A crowd character's input check and sample, compiled (crowd_kernel.prepare_steady).

    Armed (core/crowd.py) after an input that went the whole way in Python without a warning
    or reset: the plan of its name list (as InputParser's), its last sample and the limits its
    next input is checked against. An input that passes every check is written into the
    character's CrowdSlot motion arrays (shared here), as JacketSimulation.prepare and
    crowd_kernel.load_motion would have written it. Apart from the slot: copying a slot's
    many arrays out of the crowd's list costs more than this check.
    """

    joint_from: np.ndarray          # int64: as InputParser's plan of the name list
    joint_to: np.ndarray
    world_from: np.ndarray
    world_to: np.ndarray
    whole_world: bool
    last_q: np.ndarray              # the last sample's joint values, root and quaternion
    last_root: np.ndarray
    last_quat: np.ndarray
    q: np.ndarray                   # the new sample, checked before it replaces the last
    root: np.ndarray
    quat: np.ndarray
    clock: np.ndarray               # int64: the last sample's stamp, dt_ns, max_steps_per_input
    limits: np.ndarray              # reset_gap (s), teleport_distance (m), teleport_angle_deg
    motion: tuple                   # the slot's q_a, q_b, quat_a, quat_b, pos_a, pos_b
    slot_clock: np.ndarray          # the slot's clock, its t_sim included
    stats: np.ndarray               # the slot's out.stats


def steady_intake(slot: 'CrowdSlot', plan: tuple = (), last: 'tuple | None' = None,
                  clock: tuple = (0, 1, 0), limits: tuple = (0.0, 0.0, 0.0)) -> SteadyIntake:
    """Return the SteadyIntake of ``slot``; without ``plan`` and ``last``, unarmed.

    ``plan``: (joint_from, joint_to, world_from, world_to, whole_world), as
    InputParser.plan's; ``last``: (q, root, quaternion) of the last sample.
    """
    q = slot.q_a.shape[0]
    joint_from, joint_to, world_from, world_to, whole = plan or ((), (), (), (), False)
    last_q, last_root, last_quat = last or (np.zeros(q), np.eye(4), np.zeros(4))
    return SteadyIntake(ints(joint_from), ints(joint_to), ints(world_from), ints(world_to),
                        bool(whole), floats(last_q).copy(), floats(last_root).copy(),
                        floats(last_quat).copy(), np.zeros(q), np.eye(4), np.zeros(4),
                        ints(clock).copy(), floats(limits).copy(),
                        (slot.q_a, slot.q_b, slot.quat_a, slot.quat_b, slot.pos_a, slot.pos_b),
                        slot.clock, slot.out.stats)


class CrowdSlot(NamedTuple):
    """One character of a crowd as crowd_kernel.advance_crowd takes it, kept between inputs.

    Its state arrays are the simulation's own, moved in place; each input writes its two
    samples into the ``q_a`` .. ``pos_b`` arrays and its clock in place, so the slot is typed
    once and not per input.
    """

    model: Model
    tuning: Tuning
    state: ClothState
    before: Posed
    q_a: np.ndarray
    q_b: np.ndarray
    quat_a: np.ndarray
    quat_b: np.ndarray
    pos_a: np.ndarray
    pos_b: np.ndarray
    clock: np.ndarray               # int64: stamp_a, span, t_sim, dt_ns, steps (as Motion's)
    out: StepOutput
    bone_rc: np.ndarray             # M9 bones' (row, column), as JacketSimulation.bones
    layer_parents: np.ndarray       # M1/M2 bones' parent links (none without a layer)
    bones: np.ndarray               # (B,7) the bones' poses after the steps, as bones() gives


class Scene(NamedTuple):
    """What the markers draw at one instant."""

    links: np.ndarray
    root: np.ndarray
    x: np.ndarray
    hood_p: np.ndarray
    layer_pos: np.ndarray
    layer_tips: np.ndarray


def skeleton_model(skeleton: 'Skeleton') -> SkeletonModel:
    """Return the kinematic arrays of a core.skeleton.Skeleton."""
    return SkeletonModel(floats(skeleton.origin), floats(skeleton.axis), ints(skeleton.kind),
                         ints(skeleton.var), floats(skeleton.mult), floats(skeleton.offset),
                         ints(skeleton.parent))


def layer_model(layer: 'BoneLayer | None' = None) -> LayerModel:
    """Return a core.bone_layer.BoneLayer's arrays; an empty layer for ``None``."""
    from .bone_layer import DOWN
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


def cloth_model(rig: 'Rig') -> ClothModel:
    """Return a core.rig.Rig's cloth, pins, references and hood."""
    pinned_a, pinned_b = ~rig.free[rig.con_a], ~rig.free[rig.con_b]
    held, top_row = rig.horiz & ~(pinned_a & pinned_b), rig.horiz & pinned_a & pinned_b
    # Row by row, as the hard pass walks them (kernel.hard_pass_with_strain_limit).
    held = np.flatnonzero(held)[np.argsort(rig.con_a[held] // rig.cols, kind='stable')]
    return ClothModel(
        int(rig.pin_link), floats(rig.pin_local), ints(rig.reference_link),
        floats(rig.reference_local), ints(rig.pin_below), floats(rig.pin_below_local),
        floats(rig.pin_weight), flags(rig.free), ints(rig.con_a), ints(rig.con_b),
        floats(rig.con_rest), ints(rig.vert_a), ints(rig.vert_b), floats(rig.vert_rest),
        ints(rig.con_a[held]), ints(rig.con_b[held]), floats(rig.con_rest[held]),
        ints(rig.con_a[top_row]), floats(rig.con_rest[top_row]), ints(rig.tether_anchor),
        floats(rig.tether_length), int(rig.hood.link),
        floats(rig.hood.pivot), float(rig.hood.length), floats(rig.hood.side), floats(rig.up))


def collider_model(rig: 'Rig') -> ColliderModel:
    """Return a core.rig.Rig's colliders in their links' frames."""
    return ColliderModel(
        ints(rig.collider_links), floats(rig.collider_centers), floats(rig.collider_rotations),
        floats(rig.collider_radii), ints(rig.capsule_links), floats(rig.capsule_ends),
        floats(rig.capsule_radii), ints(rig.plane_links), floats(rig.plane_points),
        floats(rig.plane_normals))


def model_of(skeleton: 'Skeleton', rig: 'Rig') -> Model:
    """Return the fixed bundle of a skeleton and the rig fitted to it."""
    return Model(skeleton.model, rig.layer.model if rig.layer else layer_model(), cloth_model(rig),
                 collider_model(rig))


def posed_like(colliders: ColliderModel, n: int) -> Posed:
    """Zeroed arrays for where ``colliders`` and ``n`` references are at one instant."""
    k = len(colliders.capsule_links)
    return Posed(np.zeros(colliders.centers.shape), np.zeros(colliders.rotations.shape),
                 np.zeros((k, 3)), np.zeros((k, 3)), np.zeros(colliders.plane_points.shape),
                 np.zeros(colliders.plane_normals.shape), np.zeros((n, 3)))


def copied(bundle: _Bundle) -> _Bundle:
    """Return a copy of a bundle (nested ones too) with new arrays of the same values."""
    if hasattr(bundle, '_fields'):
        return type(bundle)(*(copied(v) for v in bundle))
    if isinstance(bundle, tuple):
        return tuple(copied(v) for v in bundle)
    return bundle.copy() if isinstance(bundle, np.ndarray) else bundle
