# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The named bundles of arrays that the compiled steps take, each built in one place.

As NVIDIA Warp's sim passes ``model, state, control``, the kernels take a few named tuples
instead of long positional lists, so two neighbouring arrays of one dtype and shape can no
longer be swapped by a caller:

- :class:`Model`: what never changes while a character runs (skeleton, M1/M2 layer, cloth
  topology and pins, colliders in their links' frames), built by ``rig.model_of``;
- :class:`Tuning`: the fabric's and the parameters' values, rebuilt on a live change
  (``JacketSimulation``);
- :class:`ClothState`: cloth, hood and root, moved in place by the steps;
- :class:`Posed`: colliders and M11 references in the simulation frame at one instant;
  :class:`Colliders`, every collider there, and :class:`Body`, the same as the push-outs
  read them;
- :class:`Motion` and :class:`StepControl`: what drives one input's steps or one cloth step;
  :class:`NamePlan` and :class:`JointSample`: where a message's names go, and a sample;
- :class:`StepOutput`: what the steps leave for the bones and the report, and the sleeves'
  twist the next solve follows; :class:`StepScratch`, their working arrays;
- :class:`CrowdSlot`: one character of a crowd, for the crowd's one compiled call, and
  :class:`SteadyIntake`, the compiled check of its steady inputs.

This is the bottom layer of core: it imports nothing of the package. Every builder (here,
and where a skeleton, a rig or a bone layer builds its own) fixes each field's dtype and
memory layout, so the compiled code sees the same types on every call (see
compiled.FixedTypes). The compiled code depends on the fields' order, so an edit here
recompiles every kernel (compiled.kernel_files).
"""

from typing import NamedTuple, TypeVar

import numpy as np
import numpy.typing as npt

_Bundle = TypeVar('_Bundle')


def floats(a: npt.ArrayLike) -> np.ndarray:
    """Return ``a`` as a C-contiguous float64 array (the kernels' float type).

    :param a: any array-like of numbers.
    """
    return np.ascontiguousarray(a, dtype=np.float64)


def ints(a: npt.ArrayLike) -> np.ndarray:
    """Return ``a`` as a C-contiguous int64 array (the kernels' index type).

    :param a: any array-like of integers.
    """
    return np.ascontiguousarray(a, dtype=np.int64)


def flags(a: npt.ArrayLike) -> np.ndarray:
    """Return ``a`` as a C-contiguous boolean array.

    :param a: any array-like of truth values.
    """
    return np.ascontiguousarray(a, dtype=np.bool_)


class SkeletonModel(NamedTuple):
    """The skeleton for forward kinematics (links in breadth-first order, see Skeleton)."""

    origin: np.ndarray      # (L,4,4) joint origin in the parent link's frame
    axis: np.ndarray        # (L,3) joint axis
    kind: np.ndarray        # (L,) physics.pose.FIXED, ROTATION or TRANSLATION
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


class Colliders(NamedTuple):
    """Every collider in the simulation frame at one instant (Posed's, with their radii)."""

    centers: np.ndarray             # ellipsoids (M10): (E,3) centres, (E,3,3) axes as columns,
    axes: np.ndarray                # (E,3) radii
    radii: np.ndarray
    capsule_a: np.ndarray           # capsules: (K,3) segment ends, (K,) radii
    capsule_b: np.ndarray
    capsule_radii: np.ndarray
    plane_points: np.ndarray        # planes: (P,3) a point and the unit normal
    plane_normals: np.ndarray


class Body(NamedTuple):
    """Colliders as the push-outs read them (physics.colliders.body_of), once per pass.

    Each ellipsoid as the map into the space where it is a unit sphere, the map back, and the
    squared radius of its bounding sphere, so the per-vertex test multiplies, never divides.
    """

    centers: np.ndarray
    to_unit: np.ndarray
    from_unit: np.ndarray
    reach2: np.ndarray
    cap_a: np.ndarray
    cap_b: np.ndarray
    cap_r: np.ndarray
    plane_p: np.ndarray
    plane_n: np.ndarray


class NamePlan(NamedTuple):
    """Where each value of a JointState with one name list goes (inputs.InputParser.plan)."""

    joint_from: np.ndarray          # int64: message index -> skeleton joint index
    joint_to: np.ndarray
    world_from: np.ndarray          # int64: message index -> world_joint variable
    world_to: np.ndarray
    whole_world: bool               # every world variable is there
    wraps: np.ndarray               # bool per joint value taken: a continuous joint's angle


class JointSample(NamedTuple):
    """A skeleton sample's arrays: joint values, the root's world pose and its quaternion."""

    q: np.ndarray
    root: np.ndarray                # (4,4)
    quat: np.ndarray                # (4,) x, y, z, w


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
    """What drives one cloth step (physics.cloth.cloth_step)."""

    acc: np.ndarray                 # (N,3) gravity and wind, simulation frame
    damping: np.ndarray             # (N,) per substep
    contact_damping: float          # per substep
    dt: float                       # s
    substeps: int
    pin_from: np.ndarray            # (N,3) pinned vertices at the step's start


class StepOutput(NamedTuple):
    """What advance leaves: the last step's pose, its layer bones, the stats, and the twist.

    ``sleeve_twist`` is also read: each full solve of the layer follows it.
    """

    links: np.ndarray
    layer_rot: np.ndarray
    layer_pos: np.ndarray
    layer_tips: np.ndarray
    below: np.ndarray
    stats: np.ndarray
    # (S,) each M1 sleeve's twist as the last full solve took it (unwrapped); NaN: none since
    # the last reset.
    sleeve_twist: np.ndarray


class SteadyIntake(NamedTuple):
    """A character's input check and sample, compiled (physics.crowd.steady_input).

    Armed (core/stepping.py) after an input that went the whole way in Python without a warning
    or reset: the plan of its name list (as InputParser's), its last sample and the limits its
    next input is checked against. An input that passes every check is written into the
    character's CrowdSlot motion arrays (shared here), as JacketSimulation.prepare and
    physics.crowd.load_motion would have written it. Apart from the slot: copying a slot's
    many arrays out of the crowd's list costs more than this check.
    """

    plan: NamePlan
    last: JointSample               # the last sample
    new: JointSample                # the new sample, checked before it replaces the last
    clock: np.ndarray               # int64: the last sample's stamp, dt_ns, max_steps_per_input
    limits: np.ndarray              # reset_gap (s), teleport_distance (m), teleport_angle_deg
    motion: tuple                   # the slot's q_a, q_b, quat_a, quat_b, pos_a, pos_b
    slot_clock: np.ndarray          # the slot's clock, its t_sim included
    stats: np.ndarray               # the slot's out.stats


def name_plan(joint_from: tuple = (), joint_to: tuple = (), world_from: tuple = (),
              world_to: tuple = (), whole_world: bool = False, wraps: tuple = ()) -> NamePlan:
    """Return a NamePlan with its index arrays as int64.

    :param joint_from: message index of each joint value the plan takes.
    :param joint_to: the skeleton joint index each goes to.
    :param world_from: message index of each world_joint variable the plan takes.
    :param world_to: the world_joint variable each goes to.
    :param whole_world: whether every world_joint variable is in the message.
    :param wraps: whether each joint value taken is a continuous joint's (an angle that
        wraps); empty: none is.
    """
    return NamePlan(ints(joint_from), ints(joint_to), ints(world_from), ints(world_to),
                    bool(whole_world),
                    np.asarray(wraps if len(wraps) else [False] * len(joint_from), dtype=bool))


def joint_sample(q: npt.ArrayLike, root: npt.ArrayLike, quat: npt.ArrayLike) -> JointSample:
    """Return a JointSample of new C float64 arrays with the values given.

    :param q: joint values, radians or metres by joint type.
    :param root: the root's world pose, 4x4.
    :param quat: the root's orientation as a quaternion (x, y, z, w).
    """
    return JointSample(floats(q).copy(), floats(root).copy(), floats(quat).copy())


def steady_intake(slot: 'CrowdSlot', plan: NamePlan | None = None,
                  last: 'tuple | None' = None, clock: tuple = (0, 1, 0),
                  limits: tuple = (0.0, 0.0, 0.0)) -> SteadyIntake:
    """Return the SteadyIntake of ``slot``; without ``plan`` and ``last``, unarmed.

    :param slot: the character's crowd slot, whose motion arrays the intake writes.
    :param plan: where each value of the steady name list goes.
    :param last: (q, root, quaternion) of the last sample.
    :param clock: the last sample's stamp (ns), dt_ns and max_steps_per_input.
    :param limits: reset_gap (s), teleport_distance (m) and teleport_angle_deg.
    """
    q = slot.q_a.shape[0]
    last = last or (np.zeros(q), np.eye(4), np.zeros(4))
    return SteadyIntake(plan or name_plan(), joint_sample(*last),
                        joint_sample(np.zeros(q), np.eye(4), np.zeros(4)),
                        ints(clock).copy(), floats(limits).copy(),
                        (slot.q_a, slot.q_b, slot.quat_a, slot.quat_b, slot.pos_a, slot.pos_b),
                        slot.clock, slot.out.stats)


class StepScratch(NamedTuple):
    """A character's working arrays for its steps (physics.step.advance), made once.

    Made anew for each input, each was an allocation and an atomic reference count in and out
    of every call it was handed to. The steps write each
    before they read it, within the step, but ``damp`` at an input's first step and when its
    substeps change, and ``new_root``'s last row, which :func:`step_scratch` sets once.
    """

    q: np.ndarray                   # the skeleton at this step (M7)
    quat: np.ndarray
    new_root: np.ndarray            # the root's world pose at this step
    delta: np.ndarray               # the root's move since the last step (M14)
    moved: np.ndarray
    gravity: np.ndarray             # gravity and wind in the local frame
    wind: np.ndarray
    acc: np.ndarray                 # (N,3) per vertex
    hood_acc: np.ndarray
    top: np.ndarray                 # (C,3) the pinned row (M6)
    now: Posed                      # colliders and M11 references at this step
    damp: np.ndarray                # (N,) damping per substep
    ride: np.ndarray                # (N,3) the cloth riding its top row (level of detail)
    x0: np.ndarray                  # (N,3) the cloth where the step starts, for a retry
    xp0: np.ndarray
    contact0: np.ndarray            # (N,) bool
    hem: np.ndarray                 # (C,3) the hem where the step starts (its path, HEM_PATH)


def step_scratch(colliders: ColliderModel, joints: int, n: int, cols: int) -> StepScratch:
    """Return a character's StepScratch.

    :param colliders: its colliders, which the steps pose.
    :param joints: its skeleton's joints.
    :param n: the cloth's vertices.
    :param cols: the cloth's columns (its pinned row).
    """
    return StepScratch(np.zeros(joints), np.zeros(4), np.eye(4), np.zeros((4, 4)), np.zeros(3),
                       np.zeros(3), np.zeros(3), np.zeros((n, 3)), np.zeros(3),
                       np.zeros((cols, 3)), posed_like(colliders, n), np.zeros(n),
                       np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                       np.zeros(n, dtype=bool), np.zeros((cols, 3)))


class CrowdSlot(NamedTuple):
    """One character of a crowd as physics.crowd.advance_crowd takes it, kept between inputs.

    Its state arrays are the simulation's own, moved in place; each input writes its two
    samples into the ``q_a`` .. ``pos_b`` arrays and its clock in place, so the slot is typed
    once and not per input.
    """

    model: Model
    tuning: Tuning
    state: ClothState
    before: Posed
    work: StepScratch
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


class MeshModel(NamedTuple):
    """A skinned mesh as the compiled draw reads it (core.jacket_mesh.SkinnedMesh, shaded)."""

    inverse_rest: np.ndarray        # (J,3,4) each joint's inverse at rest
    joints: np.ndarray              # (V,K) int64 joint of each influence, (V,K) its weight
    weights: np.ndarray
    rest: np.ndarray                # (V,3) the rest mesh
    triangles: np.ndarray           # (T,3) int64 corners; (F,3) the front faces, for normals
    front: np.ndarray
    colors: np.ndarray              # (T,4) each triangle's base colour; (T,) bool a back face
    back: np.ndarray


class Scene(NamedTuple):
    """What the markers draw at one instant."""

    links: np.ndarray
    root: np.ndarray
    x: np.ndarray
    hood_p: np.ndarray
    layer_pos: np.ndarray
    layer_tips: np.ndarray


def posed_like(colliders: ColliderModel, n: int) -> Posed:
    """Zeroed arrays for where ``colliders`` and ``n`` references are at one instant.

    :param colliders: the model whose colliders are posed.
    :param n: how many M11 references.
    """
    k = len(colliders.capsule_links)
    return Posed(np.zeros(colliders.centers.shape), np.zeros(colliders.rotations.shape),
                 np.zeros((k, 3)), np.zeros((k, 3)), np.zeros(colliders.plane_points.shape),
                 np.zeros(colliders.plane_normals.shape), np.zeros((n, 3)))


def copied(bundle: _Bundle) -> _Bundle:
    """Return a copy of a bundle (nested ones too) with new arrays of the same values.

    :param bundle: a named tuple of arrays, numbers and bundles.
    """
    if hasattr(bundle, '_fields'):
        return type(bundle)(*(copied(v) for v in bundle))
    if isinstance(bundle, tuple):
        return tuple(copied(v) for v in bundle)
    return bundle.copy() if isinstance(bundle, np.ndarray) else bundle
