# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The seed method feature by feature (M1-M16 in the README), and what the best systems add.

Each test would fail without the feature it names; the fixed step (M7), M6, M8, M9, M11, M12,
M14's world share, M15 and M16 are in test_core_simulation.py.
"""

import numpy as np
import pytest
from conftest import body, play, stepwise

from jacket_cloth_ros.core.physics import cloth as kernel
from jacket_cloth_ros.core.physics.colliders import collide
from jacket_cloth_ros.core.physics.pose import twist_angle
from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
from jacket_cloth_ros.core.rig import load_rig, split_ellipsoid
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.core.transforms import rpy_matrix
from jacket_cloth_ros.motion.clips import joint_state_content


def _example():
    """The example skeleton with other link names, and its rig (config/examples)."""
    with open(shipped('examples/mannequin.urdf'), encoding='utf-8') as f:
        skeleton = Skeleton(f.read())
    return skeleton, load_rig(skeleton, shipped('examples/mannequin_rig.yaml'))


def _still(sim, q=None, stamp_ns=1_000_000_000, world_x=0.0):
    """One JointState of a skeleton standing at world x with joint values ``q``."""
    sk = sim.skeleton
    q = np.zeros(len(sk.joint_names)) if q is None else q
    names = list(sk.joint_names) + [f'world_joint/{v}' for v in WORLD_VARIABLES]
    report = sim.process(stamp_ns, names, list(q) + [world_x, 0.0, 0.96, 0.0, 0.0, 0.0, 1.0])
    assert not report.warnings
    return report


# -- M1 the jacket's own bones over the skeleton -----------------------------------------------
def test_m1_sleeves_have_main_and_twist_bones_that_follow_the_arm(make_sim, rig):
    sim = make_sim()
    play(sim, 'arms_up', 60, 1.5)
    names = rig.layer.names
    for arm in ('l_upper_arm', 'l_forearm', 'r_upper_arm', 'r_forearm'):
        assert f'jacket_{arm}' in names and f'jacket_{arm}_twist' in names
    # The main bone is the arm link's frame itself: it follows the arm exactly.
    k = names.index('jacket_l_upper_arm')
    link = sim.links[sim.skeleton.link('l_upper_arm')]
    assert sim.layer.rotations[k] == pytest.approx(link[:3, :3], abs=1e-12)
    assert sim.layer.positions[k] == pytest.approx(link[:3, 3], abs=1e-12)
    # The twist bone sits halfway along the segment (the elbow hinge has no twist to share).
    t = names.index('jacket_l_upper_arm_twist')
    elbow = sim.links[sim.skeleton.link('l_forearm')][:3, 3]
    assert sim.layer.positions[t] == pytest.approx((link[:3, 3] + elbow) / 2, abs=1e-12)


def test_m1_twist_bone_takes_its_share_of_the_roll():
    skeleton, rig = _example()
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'))
    q = np.zeros(len(skeleton.joint_names))
    q[skeleton.joint_index['LeftHand_roll']] = 1.0
    _still(sim, q)
    names = rig.layer.names
    forearm = sim.layer.rotations[names.index('jacket_LeftForeArm')]
    twist = sim.layer.rotations[names.index('jacket_LeftForeArm_twist')]
    axis = np.array([0.0, 0.0, -1.0])        # the forearm's segment, in its own frame
    assert twist_angle(forearm.T @ twist, axis) == pytest.approx(-0.5, abs=1e-9)
    assert twist_angle(rpy_matrix([0.3, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])) == \
        pytest.approx(0.3)


# -- M2 the upper jacket by look-at ----------------------------------------------------------
def test_m2_a_raised_arm_lifts_the_shoulder_pad_and_the_bones_below(make_sim, rig, skeleton):
    sim = make_sim()
    _still(sim)
    names = rig.layer.names
    pad, below = names.index('jacket_shoulder_pad_left'), names.index('jacket_chest_left')
    rest_pad = sim.layer.rotations[pad][:, 0].copy()
    rest_below = sim.layer.positions[below].copy()
    rest_top = sim.x[:rig.cols].copy()
    q = np.zeros(len(skeleton.joint_names))
    q[skeleton.joint_index['l_shoulder_roll']] = 1.5          # left arm out to the side
    _still(sim, q, stamp_ns=1_008_333_333)
    # The pad aims at the upper arm: it now points up, not down, and keeps looking at it.
    x = sim.layer.rotations[pad][:, 0]
    assert rest_pad[2] < -0.5 and x[2] > 0.0
    aim = sim.links[skeleton.link('l_upper_arm')] @ np.array([0.0, 0.0, -0.10, 1.0])
    assert x == pytest.approx((aim[:3] - sim.layer.positions[pad])
                              / np.linalg.norm(aim[:3] - sim.layer.positions[pad]))
    # The bone below is lifted with it but still aims straight down the torso.
    assert sim.layer.positions[below][2] > rest_below[2] + 0.05
    assert sim.layer.rotations[below][:, 0] == pytest.approx([0.0, 0.0, -1.0], abs=1e-12)
    # And the jacket's top row rises on the left side (+y), not on the right.
    lift = sim.x[:rig.cols, 2] - rest_top[:, 2]
    left = rest_top[:, 1] > 0.1
    right = rest_top[:, 1] < -0.1
    assert lift[left].max() > 0.04 and lift[right].max() < lift[left].max() / 2


def test_m2_left_right_position_constraint_keeps_the_bones_below_apart(make_sim, rig,
                                                                       skeleton):
    sim = make_sim()
    rest = rig.layer.solve(sim.links)
    q = np.zeros(len(skeleton.joint_names))
    q[skeleton.joint_index['l_shoulder_roll']] = 1.5
    q[skeleton.joint_index['r_shoulder_roll']] = -0.8
    pose = rig.layer.solve(skeleton.forward(q))
    gap = np.linalg.norm(pose.below[1, :3, 3] - pose.below[0, :3, 3])
    rest_gap = np.linalg.norm(rest.below[1, :3, 3] - rest.below[0, :3, 3])
    assert gap == pytest.approx(rest_gap, abs=1e-12)
    # Without it, the pad ends would have spread apart.
    raw_gap = rig.layer.pad_ends_gap(skeleton.forward(q))
    assert abs(raw_gap - rest_gap) > 0.02


# -- M3 a coarse grid that drives bones ------------------------------------------------------
def test_m3_the_coarse_grid_drives_the_bones(make_sim, rig):
    sim = make_sim()
    play(sim, 'walk', 60, 0.5)
    assert rig.n <= 200                         # a low-resolution cloth, not a render mesh
    before = sim.bones().translations.copy()
    k = rig.bone_vertices().index((5, 4))
    sim.x[5 * rig.cols + 4] += [0.0, 0.0, -0.01]
    sim.ready_bones = None                  # the input's bones were made before that move
    after = sim.bones().translations
    assert after[k] == pytest.approx(before[k] + [0.0, 0.0, -0.01])
    assert np.array_equal(np.delete(after, k, axis=0), np.delete(before, k, axis=0))


# -- M4 Verlet with damping, gravity and wind; M5 two constraint groups ----------------------
def test_m4_verlet_step_with_damping_and_acceleration():
    x = np.array([[0.0, 0.0, 1.0]])
    xp = np.array([[-0.02, 0.0, 1.0]])           # moving +x by 2 cm a step
    acc = np.array([[0.0, 0.0, -9.81]])
    kernel.integrate(x, xp, np.array([True]), acc, np.array([0.1]), np.array([False]), 0.0,
                     0.01)
    assert x[0] == pytest.approx([0.02 * 0.9, 0.0, 1.0 - 9.81e-4])
    assert xp[0] == pytest.approx([0.0, 0.0, 1.0])


def test_m4_wind_pushes_the_cloth_downwind(make_sim, rig):
    still, windy = make_sim(), make_sim(wind=(6.0, 0.0, 0.0))
    for sim in (still, windy):
        play(sim, 'idle', 60, 1.5)
    hem = slice((rig.rows - 1) * rig.cols, rig.n)
    assert windy.x[hem, 0].mean() > still.x[hem, 0].mean() + 0.02


def test_m5_stretch_and_shear_bend_groups_have_their_own_stiffness():
    # A stretch constraint 0-1 and a bend constraint 0-2, both 10% too long.
    x0 = np.array([[0.0, 0, 0], [1.1, 0, 0], [2.2, 0, 0]])
    free = np.ones(3, dtype=np.bool_)
    ca, cb = np.array([0, 0]), np.array([1, 2])
    rest = np.array([1.0, 2.0])
    errors = {}
    for bend in (0.0, 1.0):
        x = x0.copy()
        kernel.relax(x, free, ca, cb, rest, np.array([1.0, bend]), 1, 0.0)
        errors[bend] = np.linalg.norm(x[2] - x[0]) - 2.0
    assert errors[0.0] > errors[1.0] + 0.05       # a free bend group leaves its error alone


@pytest.mark.parametrize('stretch, within', [(1.05, 5e-5), (0.92, 3e-4), (1.11, 1e-3),
                                             (1.5, 1e-12), (0.5, 1e-12)])
def test_m5_one_sweep_brings_a_constraint_to_its_rest_length(stretch, within):
    """Near rest the correction is kernel.relax's series, beyond its reach the exact one.

    The series' error grows as the fourth power of the stretch: 3e-5 of the rest length at
    5 %, under 1e-3 at 11 %; at 50 % stretch or compression the projection is exact.
    """
    x = np.array([[0.0, 0.0, 0.0], [0.6 * stretch, 0.8 * stretch, 0.0]])
    kernel.relax(x, np.ones(2, dtype=np.bool_), np.array([0]), np.array([1]), np.array([1.0]),
                 np.array([1.0]), 1, 0.0)
    error = abs(np.linalg.norm(x[1] - x[0]) - 1.0)
    assert error < within
    if within > 1e-12:              # the series, not the exact correction
        assert error > within / 20
    assert np.allclose((x[0] + x[1]) / 2, [0.3 * stretch, 0.4 * stretch, 0.0])   # both ends


# -- M10 ellipsoids (split), capsules and planes ----------------------------------------------
def test_m10_no_particle_left_inside_an_ellipsoid_including_a_split_one():
    pieces = split_ellipsoid([0.0, 0.0, 0.0], np.eye(3), [0.08, 0.08, 0.3])
    centers = np.array([c for c, _, _ in pieces])
    axes = np.array([r for _, r, _ in pieces])
    radii = np.array([r for _, _, r in pieces])
    rng = np.random.default_rng(3)
    x = rng.uniform([-0.08, -0.08, -0.3], [0.08, 0.08, 0.3], size=(400, 3))
    contact = np.zeros(len(x), dtype=np.bool_)
    was_inside = np.zeros(len(x), dtype=bool)
    for c, r in zip(centers, radii):
        was_inside |= (((x - c) / r) ** 2).sum(axis=1) < 1.0
    collide(x, np.ones(len(x), dtype=np.bool_), body(centers=centers, axes=axes, radii=radii),
            contact)
    for c, r in zip(centers, radii):
        inside = (((x - c) / r) ** 2).sum(axis=1)
        assert inside.min() >= 1.0 - 1e-9
    assert was_inside.sum() > 100 and (contact == was_inside).all()   # M15 sees every contact


def test_capsule_and_plane_colliders_push_out_and_mark_contact():
    x = np.array([[0.03, 0.0, 0.1], [0.0, 0.0, -0.5], [0.5, 0.5, -0.02], [0.5, 0.5, 0.2]])
    contact = np.zeros(4, dtype=np.bool_)
    deepest = collide(
        x, np.ones(4, dtype=np.bool_),
        body(capsule_a=[[0.0, 0.0, 0.0]], capsule_b=[[0.0, 0.0, 0.3]], capsule_radii=[0.08],
             plane_points=[[0.0, 0.0, -0.1]], plane_normals=[[0.0, 0.0, 1.0]]), contact)
    assert x[0] == pytest.approx([0.08, 0.0, 0.1])          # out of the capsule, sideways
    assert x[1][2] == pytest.approx(-0.1)                   # onto the plane
    assert x[2][2] == pytest.approx(-0.02)                  # above the plane: untouched
    assert contact.tolist() == [True, True, False, False] and deepest == pytest.approx(0.4)


def test_example_rig_uses_capsules_and_the_floor_and_runs_on_another_skeleton():
    skeleton, rig = _example()
    assert [c.name for c in rig.capsules] == ['l_thigh', 'r_thigh']
    assert [p.name for p in rig.planes] == ['floor']
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'))
    q = np.zeros(len(skeleton.joint_names))
    swing = skeleton.joint_index['LeftUpLeg_swing']
    for k in range(120):
        q[swing] = -1.2 * np.sin(np.pi * k / 120)          # kick the left thigh forward
        report = _still(sim, q, stamp_ns=1_000_000_000 + k * 16_666_667)
        assert report.accepted and not report.reset or k == 0
    c = sim.collider_frames(sim.links)
    floor_height = (sim.x - c.plane_points[0]) @ c.plane_normals[0]
    assert floor_height.min() > 0.0
    assert np.isfinite(sim.bones().translations).all()
    assert len(sim.bones().names) == len(rig.bone_vertices()) + 1 + 12


# -- M13 edges with their own parameters ------------------------------------------------------
def test_m13_edge_vertices_get_their_own_parameters(make_sim, rig):
    sim = make_sim()
    f = sim.fabric
    plain = (rig.region_scale['damping_scale'] == 1) & (rig.region_scale['wind_scale'] == 1)
    edge, inner = rig.edge & plain, ~rig.edge & plain     # outside the rig's regions
    t = sim.tuning
    assert (t.damping[edge] == f.edge_damping).all() and (t.damping[inner] == f.damping).all()
    assert (sim.tuning.world_share[edge] == f.edge_world_share).all()
    assert (sim.tuning.wind_scale[edge] == f.edge_wind_scale).all()
    assert (sim.tuning.max_distance[edge] > rig.max_distance[edge]).all()
    # The hem (an edge) flaps in the wind more than the row above it.
    windy = make_sim(wind=(0.0, 8.0, 0.0), wind_gust=0.8, wind_gust_period=0.7)
    rows = []
    for _ in stepwise(windy, 'idle', 60, 2.0):
        rows.append(windy.x.reshape(rig.rows, rig.cols, 3)[:, 4].copy())
    travel = np.abs(np.diff(np.array(rows), axis=0)).sum(axis=(0, 2))
    assert travel[-1] > travel[-2]


# -- M14 local motion followed fully --------------------------------------------------------
def test_m14_local_torso_motion_is_followed_fully_whatever_the_world_share(make_sim, rig):
    runs = []
    for share in (0.1, 1.0):
        sim = make_sim()
        sim.set_fabric(sim.fabric.with_values(world_share=share, edge_world_share=share))
        play(sim, 'arms_up', 60, 2.5)        # arms and shoulders only: no world motion
        runs.append(sim.x.copy())
    assert np.array_equal(runs[0], runs[1])
    # And the cloth has followed the lifted shoulders (M2): the top row is up, the rest hangs.
    assert runs[0][:rig.cols, 2].max() > rig.rest[:rig.cols, 2].max() + 0.05


# -- Beyond the article: tethers, wind over time, fast turns ---------------------------------
def test_tethers_keep_every_vertex_within_reach_of_its_pinned_anchor(make_sim, rig):
    # The projection itself: after it, no vertex is further from its anchor than its tether.
    rng = np.random.default_rng(5)
    x = rig.rest + rng.normal(0, 0.05, rig.rest.shape)
    x[:rig.cols] = rig.rest[:rig.cols]
    pulled = kernel.tethers(x, rig.free, rig.tether_anchor, rig.tether_length)
    d = np.linalg.norm(x - x[rig.tether_anchor], axis=1)
    assert pulled > 20 and (d <= rig.tether_length + 1e-12).all()
    # In a step, collisions and M11 act after the tethers and may pull a vertex out again for
    # that step; over a run the hem's overstretch beyond its tethers all but vanishes.
    over = {}
    for limit in ('none', 'tethers'):
        sim = make_sim(stretch_limit=limit)
        hem_over = []
        for k, _ in enumerate(stepwise(sim, 'run', 60, 1.5)):
            d = np.linalg.norm(sim.x - sim.x[rig.tether_anchor], axis=1)
            hem = d[-rig.cols:] / rig.tether_length[-rig.cols:] - 1.0
            if k:                                 # not the reset pose of the first sample
                hem_over.append(np.maximum(hem, 0.0).mean())
        over[limit] = np.mean(hem_over)
    assert over['none'] > 1e-3
    assert over['tethers'] < 0.1 * over['none']


def test_wind_varies_over_time_deterministically():
    p = SimParams(wind=(4.0, 0.0, 0.0), wind_gust=0.5, wind_gust_period=2.0)
    winds = np.array([p.wind_at(int(t * 1e9)) for t in np.linspace(0, 4, 81)])
    assert winds[:, 0].max() > 4.8 and winds[:, 0].min() < 3.2
    assert (winds[:, 1:] == 0).all()
    assert p.wind_at(1_234_567_890).tobytes() == p.wind_at(1_234_567_890).tobytes()
    assert SimParams(wind=(4.0, 0.0, 0.0)).wind_at(5 * 10**9).tolist() == [4.0, 0.0, 0.0]
    with pytest.raises(ValueError, match='stretch_limit'):
        SimParams(stretch_limit='glue')


def test_fast_turn_resets_to_the_skinned_pose(make_sim, skeleton):
    sim = make_sim(teleport_angle_deg=60.0)
    names, pos = joint_state_content(skeleton.joint_names, 'idle', 0.0)
    pos = np.array(pos)
    sim.process(1_000_000_000, names, pos)
    turned = pos.copy()
    yaw = np.radians(100) / 2                       # 100 deg about z in one input
    turned[names.index('world_joint/rot_z')] = np.sin(yaw)
    turned[names.index('world_joint/rot_w')] = np.cos(yaw)
    report = sim.process(1_016_666_667, names, turned)
    assert report.reset.startswith('fast turn: turned 100 deg')
    assert sim.x == pytest.approx(
        np.vstack([sim.pinned_points(sim.links, sim.layer),
                   sim.reference_points(sim.links, sim.layer)[sim.rig.cols:]]))


def test_rig_regions_scale_the_fabric_where_they_lie(make_sim, rig):
    sim = make_sim()
    f = sim.fabric
    vent = np.zeros((rig.rows, rig.cols), dtype=bool)
    vent[8:12, 3:6] = True
    vent = vent.ravel()
    inner = ~rig.edge
    assert sim.tuning.wind_scale[vent & inner] == pytest.approx(1.4 * f.wind_scale)
    assert sim.tuning.damping[vent & inner] == pytest.approx(0.8 * f.damping)
    assert sim.tuning.damping[~vent & inner] == pytest.approx(f.damping)
    assert sim.tuning.wind_scale[vent & rig.edge] == pytest.approx(1.4 * f.edge_wind_scale)


def test_m12_keeps_each_vertical_at_its_length_and_outside_the_body():
    # A column hanging over a ball: the straight line from the top vertex runs into it. The
    # lower vertex turns about the upper one onto the surface at its rest length, instead of
    # being pulled inside (and a later push-out stretching the edge).
    from jacket_cloth_ros.core.physics.cloth import hard_vertical_pass_outside
    x = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -0.3], [0.0, 0.0, -0.6]])
    upper, lower, rest = np.array([0, 1]), np.array([1, 2]), np.array([0.2, 0.2])
    center, radius = np.array([0.05, 0.0, -0.3]), 0.15
    contact = np.zeros(3, dtype=np.bool_)
    deepest = hard_vertical_pass_outside(
        x, upper, lower, rest, contact,
        body(centers=center[None], axes=np.eye(3)[None], radii=np.full((1, 3), radius)))
    assert deepest > 0.01 and contact[1]
    lengths = np.linalg.norm(x[upper] - x[lower], axis=1)
    assert np.allclose(lengths, rest, rtol=1e-3)       # alternating projections: to 0.1 %
    assert (np.linalg.norm(x[1:] - center, axis=1) >= radius - 1e-9).all()


def test_m12_leaves_a_vertex_pulled_into_the_crease_of_two_colliders_outside_both():
    # Where two colliders meet (a pelvis and a thigh raised in a cartwheel), pushing the
    # lower vertex out of one puts it into the other; before the pass walked the edge back
    # to its last point outside, it ended 10 cm inside (9 mm on the DeepMimic cartwheel).
    from jacket_cloth_ros.core.physics.cloth import hard_vertical_pass_outside
    centers, radii = np.array([[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0]]), np.array([0.6, 0.5])
    x = np.array([[0.05, 3.0, 0.0], [0.05, 0.0, 0.0]])
    hard_vertical_pass_outside(
        x, np.array([0]), np.array([1]), np.array([3.0]), np.zeros(2, dtype=np.bool_),
        body(centers=centers, axes=np.repeat(np.eye(3)[None], 2, axis=0),
             radii=np.repeat(radii[:, None], 3, axis=1)))
    assert (np.linalg.norm(x[1] - centers, axis=1) >= radii - 1e-6).all()
    assert np.linalg.norm(x[1] - x[0]) <= 3.0 + 1e-9         # shorter, as M12 allows


def test_strain_limit_shortens_overlong_horizontals_moving_free_ends_only():
    # The horizontals' strain limit (after M12): an edge over (1 + limit) rest is shortened
    # to that length, a pinned end does not move, and edges under it are left alone (folds
    # and compression are the solve's).
    from jacket_cloth_ros.core.physics.cloth import limit_stretch
    x = np.array([[0.0, 0.0, 0.0], [0.2, 0.0, 0.0], [0.5, 0.0, 0.0], [0.55, 0.0, 0.0]])
    free = np.array([False, True, True, True])
    ea, eb, rest = np.array([0, 1, 2]), np.array([1, 2, 3]), np.full(3, 0.1)
    was = x.copy()
    assert limit_stretch(x, free, ea, eb, rest, 0.05, 50) > 0
    lengths = np.linalg.norm(x[eb] - x[ea], axis=1)
    assert np.all(lengths <= 0.105 + 1e-6) and lengths[0] == pytest.approx(0.105)
    assert (x[0] == was[0]).all()
    # An edge at 0.05 (half its rest) stays compressed: only stretch is limited.
    short = np.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0]])
    assert limit_stretch(short, np.array([True, True]), ea[:1], eb[:1], rest[:1], 0.05, 2) == 0
    assert short[1, 0] == 0.05


def test_fabric_files_without_the_horizontal_limit_keep_working(tmp_path):
    # max_horizontal_stretch is optional: fabric files written before it load with the
    # default; a value out of range is refused naming file and key.
    import yaml
    from jacket_cloth_ros.core.config import ConfigError, load_yaml, shipped
    from jacket_cloth_ros.core.fabric import DEFAULT_MAX_HORIZONTAL_STRETCH, load_fabric
    data = load_yaml(shipped('fabrics.yaml'))
    data['tweed_jacket'].pop('max_horizontal_stretch', None)
    path = tmp_path / 'fabrics.yaml'
    path.write_text(yaml.safe_dump(data))
    fabric = load_fabric('tweed_jacket', str(path))
    assert fabric.max_horizontal_stretch == DEFAULT_MAX_HORIZONTAL_STRETCH
    data['tweed_jacket']['max_horizontal_stretch'] = -0.1
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match='max_horizontal_stretch'):
        load_fabric('tweed_jacket', str(path))
