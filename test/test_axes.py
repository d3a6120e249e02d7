# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""No hidden axis conventions (issue 18): the same character with other link axes, same cloth.

The shipped character is re-expressed with every link frame turned (test/reframe.py): Y-up as
in BVH and game skeletons, or a random turn per link. Its rig and motion are re-expressed with
it, so the simulation must give the same cloth, hood and bones, up to the frame change.
"""

import numpy as np
import pytest
import yaml
from conftest import clip_inputs
from reframe import (
    Y_UP, random_rotations, root_link, rotate_joint_state, rotate_pose, rotate_rig, rotate_urdf)

from jacket_cloth_ros.core.config import ConfigError, load_yaml, shipped
from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.rig import Rig
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
from jacket_cloth_ros.core.transforms import quat_to_matrix

WIND = np.array([1.5, -0.8, 0.3])       # world frame: the variant's world is turned too


def _world_bones(sim):
    """Every published bone's world pose (4x4), from its pose relative to its parent link."""
    bones = sim.bones()
    out = []
    for name, parent, pose in zip(bones.names, bones.parents, bones.poses):
        local = np.eye(4)
        local[:3, :3] = quat_to_matrix(pose[3:])
        local[:3, 3] = pose[:3]
        out.append(sim.root @ sim.links[sim.skeleton.link(parent)] @ local)
    return np.array(out)


def _run(urdf, rig_data, inputs, world=None):
    skeleton = Skeleton(urdf)
    rig = Rig(rig_data, skeleton)
    wind = WIND if world is None else world.T @ WIND
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket'),
                           SimParams(wind=tuple(wind), wind_gust=0.3))
    frames = []
    for stamp, names, pos in inputs:
        if world is not None:
            pos = rotate_joint_state(names, pos, world)
        assert sim.process(stamp, names, pos).accepted
        cloth = sim.x @ sim.root[:3, :3].T + sim.root[:3, 3]
        hood = sim.root[:3, :3] @ sim.hood_p + sim.root[:3, 3]
        frames.append((cloth, hood, _world_bones(sim), sim.root.copy()))
    return sim, frames


@pytest.mark.parametrize('variant', ['y_up', 'y_up_explicit', 'random'])
def test_turned_link_frames_give_the_same_cloth(variant):
    """Cloth, hood and bones in the world agree to 1e-9 m with the link frames turned."""
    urdf = shipped_character_urdf()
    data = load_yaml(shipped('jacket_rig.yaml'))
    names = Skeleton(urdf).link_names
    rotations = random_rotations(names, seed=3) if variant == 'random' else Y_UP
    rotation_of = rotations.get if isinstance(rotations, dict) else (lambda n: Y_UP)
    root = root_link(urdf)
    world = rotation_of(root)
    original = Rig(data, Skeleton(urdf))
    axes_at = ((lambda n: original.axes_at(original.skeleton.link(n)))
               if variant == 'y_up_explicit' else None)
    turned_urdf = rotate_urdf(urdf, rotations)
    turned_rig = rotate_rig(data, rotations, root, axes_at)
    if variant.startswith('y_up'):
        # The BVH convention: y up, x forward, bones along -y; the world is Y-up too.
        assert turned_rig['up'] == pytest.approx([0.0, 1.0, 0.0], abs=1e-15)
        assert turned_rig['forward'] == pytest.approx([1.0, 0.0, 0.0], abs=1e-15)
        rest = Skeleton(turned_urdf).forward(np.zeros(len(Skeleton(turned_urdf).joint_names)))
        knee, foot = (rest[Skeleton(turned_urdf).link(n)][:3, 3] for n in ('l_shin', 'l_foot'))
        assert (foot - knee) @ [0, -1, 0] == pytest.approx(np.linalg.norm(foot - knee))
    # The rig as YAML, the way a user (or the rig proposer) writes it.
    turned_rig = yaml.safe_load(yaml.safe_dump(turned_rig))
    inputs = clip_inputs(Skeleton(urdf), 'showcase', 3.0, rate=60.0)
    inputs += clip_inputs(Skeleton(urdf), 'walk', 1.5, start_s=13.0, rate=60.0)
    sim_a, a = _run(urdf, data, inputs)
    sim_b, b = _run(turned_urdf, turned_rig, inputs, world)
    assert sim_a.resets == sim_b.resets == 1
    sleeves = {s.name for s in sim_a.rig.layer.sleeves}
    link_bones = [k for k, n in enumerate(sim_a.bone_names)
                  if n in sleeves or n.removesuffix('_twist') in sleeves]
    assert len(link_bones) == 8         # the M1 sleeve and twist bones: turned with their link
    for (cloth, hood, bones, root), (cloth_t, hood_t, bones_t, root_t) in zip(a, b):
        assert root_t == pytest.approx(rotate_pose(root, world), abs=1e-12)
        assert cloth_t == pytest.approx(cloth @ world, abs=1e-9)
        assert hood_t == pytest.approx(world.T @ hood, abs=1e-9)
        expected = _turn(world).T @ bones
        for k in link_bones:            # a sleeve bone is its link's frame, itself turned
            expected[k] = expected[k] @ _turn(rotation_of(sim_a.bone_parents[k]))
        assert bones_t[:, :3, 3] == pytest.approx(expected[:, :3, 3], abs=1e-9)
        # A published quaternion's components near zero come from a square root (Shepperd's
        # method), so its frame holds to sqrt(machine epsilon), not 1e-9.
        assert bones_t[:, :3, :3] == pytest.approx(expected[:, :3, :3], abs=1e-7)
    # The cloth moved: the comparison is not of two rest poses.
    assert np.abs(a[-1][0] - a[0][0]).max() > 0.5


def _turn(rotation):
    r = np.eye(4)
    r[:3, :3] = rotation
    return r


def test_default_axes_are_the_shipped_convention(skeleton):
    """With links parallel to the world, no up/forward and no rpy_deg are the old link axes."""
    data = load_yaml(shipped('jacket_rig.yaml'))
    plain = Rig(data, skeleton)
    spelled = dict(data, up=[0, 0, 1], forward=[1, 0, 0])
    spelled['cloth'] = dict(data['cloth'], shape=dict(data['cloth']['shape'], rpy_deg=[0, 0, 0]))
    upper = dict(data['jacket_bones']['upper'], rpy_deg=[0, 0, 0])
    spelled['jacket_bones'] = dict(data['jacket_bones'], upper=upper)
    explicit = Rig(spelled, skeleton)
    assert np.array_equal(plain.rest, explicit.rest)
    assert np.array_equal(plain.layer.down, explicit.layer.down)
    assert np.array_equal(plain.hood.side, [0.0, 1.0, 0.0])


def test_rpy_deg_turns_the_shape_about_its_link(skeleton):
    """A shape turned 90 degrees about up opens to the left instead of the front."""
    data = load_yaml(shipped('jacket_rig.yaml'))
    turned = dict(data)
    turned['cloth'] = dict(data['cloth'], shape=dict(data['cloth']['shape'], rpy_deg=[0, 0, 90]))
    a, b = Rig(data, skeleton), Rig(turned, skeleton)
    # The front edges' midpoint is in front (+x) of the body, then on its left (+y).
    front = (a.rest[0] + a.rest[a.cols - 1]) / 2
    left = (b.rest[0] + b.rest[b.cols - 1]) / 2
    spine = skeleton.forward(np.zeros(len(skeleton.joint_names)))[skeleton.link('spine')][:3, 3]
    assert (front - spine)[0] > 0.1 and (left - spine)[1] > 0.1


@pytest.mark.parametrize('change, message', [
    ({'up': [0, 0, 0]}, 'rig.up: [0.0, 0.0, 0.0] must not be zero'),
    ({'forward': [0.0, 0.0, 0.0]}, 'rig.forward: [0.0, 0.0, 0.0] must not be zero'),
    ({'up': [1, 0, 0]}, 'rig: up [1.0, 0.0, 0.0] and forward [1.0, 0.0, 0.0] are parallel'),
    ({'up': [0, 0, 1], 'forward': [0, 0.01, -2]}, 'are parallel'),
    ({'up': [0, float('nan'), 1]}, 'rig.up: [0, nan, 1] has a number that is not finite'),
    ({'forward': [1, 0]}, 'rig.forward: expected a list of 3 numbers'),
    ({'shape_rpy': [0, 0, 400]}, 'rig.cloth.shape.rpy_deg: [0, 0, 400] has a number '
     'outside [-360.0, 360.0]'),
    ({'upper_rpy': [0, float('inf'), 0]}, 'rig.jacket_bones.upper.rpy_deg: [0, inf, 0] '
     'has a number that is not finite'),
])
def test_bad_axes_are_one_clear_line(skeleton, change, message):
    data = load_yaml(shipped('jacket_rig.yaml'))
    change = dict(change)
    if 'shape_rpy' in change:
        data['cloth']['shape']['rpy_deg'] = change.pop('shape_rpy')
    if 'upper_rpy' in change:
        data['jacket_bones']['upper']['rpy_deg'] = change.pop('upper_rpy')
    data.update(change)
    with pytest.raises(ConfigError) as e:
        Rig(data, skeleton)
    assert message in str(e.value) and '\n' not in str(e.value)
