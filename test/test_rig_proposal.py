# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth rig``: a rig proposed for skeletons of other names and axes (issue 18 item 2).

The public skeleton (JVRC-1 of jvrc_description, Apache-2.0) and the MocapBank capture are
fetched by ``make mocap`` into share/mocap, never committed.
"""

import re

import numpy as np
import pytest
import yaml

from jacket_cloth_ros.core.config import ConfigError, shipped
from jacket_cloth_ros.core.rig import Rig
from jacket_cloth_ros.core.skeleton import Skeleton, load_skeleton
from jacket_cloth_ros.rigging.propose import (
    Refusal, name_rank, propose, side_of, to_yaml, tokens)
from jacket_cloth_ros.tools.cli import main
from fetched import fetched


def _text(path):
    with open(path, encoding='utf-8') as f:
        return f.read()


def _rig_of(urdf_text, forward=None):
    sk = Skeleton(urdf_text)
    rig, lines, body = propose(sk, forward)
    return sk, rig, lines, body


# --- the naming tables ---------------------------------------------------------------------

@pytest.mark.parametrize('name, side, part', [
    ('l_upper_arm', 'left', 'upper_arm'),                # REP-120 / ROS humanoids
    ('r_forearm', 'right', 'forearm'),
    ('mixamorig:LeftForeArm', 'left', 'forearm'),        # Mixamo
    ('mixamorig:RightUpLeg', 'right', 'thigh'),
    ('upperarm_l', 'left', 'upper_arm'),                 # Unreal mannequin
    ('lowerarm_r', 'right', 'forearm'),
    ('thigh_l', 'left', 'thigh'),
    ('L_Shoulder', 'left', 'upper_arm'),                 # SMPL
    ('R_Wrist', 'right', 'hand'),
    ('LeftUpLeg', 'left', 'thigh'),                      # BVH / CMU
    ('RightHand', 'right', 'hand'),
    ('R_ELBOW_P_S', 'right', 'forearm'),                 # JVRC
])
def test_names_of_common_skeletons_say_side_and_part(name, side, part):
    assert side_of(name) == side
    assert name_rank(name, part) is not None


def test_an_upper_arm_name_beats_a_shoulder_name_and_words_are_cut_right():
    assert tokens('mixamorig:LeftUpLeg') == ['mixamorig', 'left', 'up', 'leg']
    assert name_rank('l_upper_arm', 'upper_arm') < name_rank('l_shoulder', 'upper_arm')
    assert side_of('spine_01') is None and side_of('Head') is None


# --- the shipped character, by names and by topology alone --------------------------------

def test_the_shipped_character_gets_its_hand_fitted_rig_back_within_centimetres():
    sk, rig, lines, body = _rig_of(_text(shipped('character.urdf')))
    chosen = {line.split(':')[0].strip(): line.split(':')[1].split()[0] for line in lines}
    assert chosen['chest'] == 'chest' and chosen['neck'] == 'neck'
    assert chosen['left upper arm'] == 'l_upper_arm'     # not l_shoulder, at the same place
    assert chosen['right forearm'] == 'r_forearm' and chosen['left thigh'] == 'l_thigh'
    assert 'up' not in rig and 'rpy_deg' not in rig['cloth']['shape']
    hand = yaml.safe_load(_text(shipped('jacket_rig.yaml')))
    assert rig['cloth']['shape']['link'] == hand['cloth']['shape']['link']
    assert np.allclose(rig['cloth']['shape']['radii'], hand['cloth']['shape']['radii'],
                       atol=0.01)
    assert np.allclose(rig['hood']['pivot'], hand['hood']['pivot'], atol=0.01)
    pad, hand_pad = (r['jacket_bones']['upper']['shoulder_pads']['left'] for r in (rig, hand))
    assert np.allclose(pad['pivot'], hand_pad['pivot'], atol=0.01)
    Rig(yaml.safe_load(to_yaml(rig, lines, 'character.urdf', body)), sk)


def _renamed(text):
    """The shipped character with every link and joint name replaced by a meaningless one."""
    names = re.findall(r'<link name="([^"]+)"', text)
    joints = re.findall(r'<joint name="([^"]+)"', text)
    for k, n in enumerate(sorted(names + joints, key=len, reverse=True)):
        text = re.sub(rf'"{re.escape(n)}"', f'"part{k:02d}"', text)
    return text


def test_a_skeleton_with_meaningless_names_is_found_by_topology_and_side():
    named = _rig_of(_text(shipped('character.urdf')))[1]
    sk, rig, lines, body = _rig_of(_renamed(_text(shipped('character.urdf'))))
    assert all(re.fullmatch(r'part\d\d', sk.link_names[k]) for k in sk.link_index.values())
    assert 'by side' in ' '.join(lines) and 'by topology' in ' '.join(lines)
    # Same places, same sizes: only the names differ (the clavicle and the upper arm sit at one
    # place, so topology takes the last of the two, the one carrying the bone).
    assert rig['cloth']['shape'] == {**named['cloth']['shape'],
                                     'link': rig['cloth']['shape']['link']}
    assert rig['hood']['pivot'] == named['hood']['pivot']
    left = rig['jacket_bones']['sleeves'][0]['link']
    assert sk.forward(np.zeros(len(sk.joint_names)))[sk.link(left)][1, 3] > 0   # on the left
    Rig(yaml.safe_load(to_yaml(rig, lines, 'renamed.urdf', body)), sk)


# --- refusal -------------------------------------------------------------------------------

def _one_armed(text):
    for link in ('r_shoulder', 'r_upper_arm', 'r_forearm', 'r_hand'):
        text = re.sub(rf'<link name="{link}"[^>]*/>|<link name="{link}">.*?</link>', '', text,
                      flags=re.S)
        text = re.sub(rf'<joint name="[^"]*"[^>]*>(?:(?!</joint>).)*<child link="{link}"/>'
                      r'.*?</joint>', '', text, flags=re.S)
    return text


def test_a_skeleton_without_two_arms_or_a_torso_is_refused_in_one_line(tmp_path, capsys):
    one_arm = tmp_path / 'one_arm.urdf'
    one_arm.write_text(_one_armed(_text(shipped('character.urdf'))))
    assert 'r_upper_arm' not in one_arm.read_text()
    assert main(['rig', '--urdf', str(one_arm), '-o', str(tmp_path / 'r.yaml')]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'cannot find two arms' in err[0], err
    assert not (tmp_path / 'r.yaml').exists()
    stick = tmp_path / 'stick.urdf'
    stick.write_text('<robot name="stick"><link name="a"/><link name="b"/><link name="c"/>'
                     '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
                     '<origin xyz="0 0 1"/><axis xyz="1 0 0"/></joint>'
                     '<joint name="k" type="fixed"><parent link="b"/><child link="c"/>'
                     '<origin xyz="0 0 1"/></joint></robot>')
    assert main(['rig', '--urdf', str(stick), '-o', str(tmp_path / 'r.yaml')]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'cannot find a torso' in err[0], err


# --- colliders from the URDF's <collision> shapes ------------------------------------------

SHAPES = {
    'base_link': '<sphere radius="0.15"/>',
    'spine': '<box size="0.26 0.34 0.40"/>',
    'chest': '<cylinder radius="0.12" length="0.44"/>',
    'l_thigh': '<cylinder radius="0.08" length="0.44"/>',
    'r_thigh': '<cylinder radius="0.08" length="0.44"/>',
}


def _with_collisions(text, shapes=None, thigh_z=-0.22):
    for link, geometry in (shapes or SHAPES).items():
        z = {'base_link': 0.0, 'spine': 0.12, 'chest': 0.1}.get(link, thigh_z)
        col = (f'<collision><origin xyz="0 0 {z}" rpy="0 0 0"/><geometry>{geometry}'
               '</geometry></collision>')
        text, n = re.subn(rf'<link name="{link}"\s*/>', f'<link name="{link}">{col}</link>',
                          text)
        if not n:
            text, n = re.subn(rf'(<link name="{link}">)', rf'\1{col}', text)
        assert n == 1, link
    return text


def _rig_yaml(colliders):
    hand = yaml.safe_load(_text(shipped('jacket_rig.yaml')))
    hand['colliders'] = colliders
    return hand


def test_colliders_from_urdf_turn_each_primitive_into_an_ellipsoid_or_a_capsule():
    sk = Skeleton(_with_collisions(_text(shipped('character.urdf'))))
    rig = Rig(_rig_yaml('from_urdf'), sk)
    by_name = {c.name: c for c in rig.colliders}
    assert np.allclose(by_name['base_link_0'].radii, 0.15)           # a sphere
    spine = [c for c in rig.colliders if c.name.startswith('spine_')]
    assert len(spine) == 1 and np.allclose(spine[0].radii, [0.13, 0.17, 0.20])  # the box's half
    caps = {c.name: c for c in rig.capsules}
    assert np.allclose(caps['chest'].a, [0, 0, 0.0]) and np.allclose(caps['chest'].b, [0, 0, .2])
    # pybullet's <capsule> (length between the caps) is read too, turned as its origin says.
    from jacket_cloth_ros.core.urdf_colliders import colliders_from_urdf
    (cap,) = colliders_from_urdf('<robot name="r"><link name="arm"><collision><origin '
                                 'xyz="0 -0.5 0" rpy="-1.5707963 0 0"/><geometry><capsule '
                                 'radius="0.1" length="0.6"/></geometry></collision></link>'
                                 '</robot>')
    assert cap['type'] == 'capsule' and cap['radius'] == 0.1
    assert np.allclose([cap['a'], cap['b']], [[0, -0.8, 0], [0, -0.2, 0]], atol=1e-6)
    assert np.allclose(caps['l_thigh'].a, [0, 0, -0.22 - 0.14]) and caps['l_thigh'].radius == 0.08
    # Some links, one dropped, one replaced, the floor added.
    rig = Rig(_rig_yaml({'from_urdf': ['spine', 'l_thigh', 'r_thigh'], 'drop': ['r_thigh'],
                         'add': [{'name': 'l_thigh', 'type': 'capsule', 'link': 'l_thigh',
                                  'a': [0, 0, 0], 'b': [0, 0, -0.4], 'radius': 0.09},
                                 {'name': 'floor', 'type': 'plane', 'link': 'world',
                                  'point': [0, 0, 0], 'normal': [0, 0, 1]}]}), sk)
    assert [c.name for c in rig.capsules] == ['l_thigh'] and rig.capsules[0].radius == 0.09
    assert [c.name for c in rig.colliders] == ['spine_0'] and len(rig.planes) == 1


@pytest.mark.parametrize('colliders, message', [
    ({'from_urdf': ['tail']}, "colliders.from_urdf: link 'tail' is not in the URDF"),
    ({'from_urdf': 'some'}, "colliders.from_urdf: 'some' is not one of ['all']"),
    ({'from_urdf': 'all', 'drop': ['nose']}, "colliders.drop: 'nose' is not a collider made"),
    ({'from_urdf': 'all', 'spare': 1}, "colliders: unknown key(s) 'spare'"),
    ('from_the_urdf', 'colliders: expected a list of colliders, from_urdf, or a mapping'),
])
def test_bad_from_urdf_settings_are_one_clear_line(colliders, message):
    sk = Skeleton(_with_collisions(_text(shipped('character.urdf'))))
    with pytest.raises(ConfigError) as e:
        Rig(_rig_yaml(colliders), sk, where='my_rig.yaml')
    assert message in str(e.value) and 'my_rig.yaml' in str(e.value) and '\n' not in str(e.value)


def test_a_urdf_without_primitive_shapes_cannot_give_colliders():
    with pytest.raises(ConfigError, match='no sphere, box, cylinder or capsule'):
        Rig(_rig_yaml('from_urdf'), load_skeleton(shipped('character.urdf')))


def test_the_proposal_uses_the_urdf_shapes_for_colliders_and_cloth_size():
    sk, rig, lines, body = _rig_of(_with_collisions(_text(shipped('character.urdf'))))
    assert rig['colliders']['from_urdf'] == ['base_link', 'spine', 'chest', 'l_thigh', 'r_thigh']
    # The shins have no shape: a capsule over each, whole length (issue 35 item 3).
    *shins, floor = rig['colliders']['add']
    assert floor['type'] == 'plane' and [c['name'] for c in shins] == ['l_shin', 'r_shin']
    assert shins[0]['link'] == 'l_shin' and shins[0]['a'] == [0.0, 0.0, 0.0]
    # The box on the spine is 0.34 m wide, the thighs' cylinders reach 0.1 + 0.08 m to the
    # side: the cloth clears the wider by 2 cm (scaled by height), or its hem starts inside.
    assert rig['cloth']['shape']['radii'][1] == pytest.approx(0.18 + 0.02 * body.height / 1.75,
                                                              abs=2e-3)
    assert 'from the <collision> shapes' in ' '.join(lines)
    Rig(yaml.safe_load(to_yaml(rig, lines, 'c.urdf', body)), sk)


def test_a_thigh_shape_far_thinner_than_the_bone_gets_a_capsule_over_the_whole_bone():
    # Issue 35 item 3: Unitree H1's 5 cm thigh cylinders cover half the thigh, and the hem went
    # through the rest. Here the thighs' cylinders are 2 cm thick and cover their top half.
    thin = dict(SHAPES, l_thigh='<cylinder radius="0.02" length="0.22"/>',
                r_thigh='<cylinder radius="0.02" length="0.22"/>')
    text = _with_collisions(_text(shipped('character.urdf')), thin, thigh_z=-0.11)
    sk, rig, lines, body = _rig_of(text)
    added = {c['name']: c for c in rig['colliders']['add']}
    rest = sk.forward(np.zeros(len(sk.joint_names)))
    knee = np.linalg.solve(rest[sk.link('l_thigh')], rest[sk.link('l_shin')][:, 3])[:3]
    assert added['l_thigh']['link'] == 'l_thigh' and np.allclose(added['l_thigh']['b'], knee,
                                                                 atol=1e-3)
    assert added['l_thigh']['radius'] == pytest.approx(0.04 * body.height, abs=1e-3)
    assert {'r_thigh', 'l_shin', 'r_shin'} <= set(added)
    assert 'a capsule over l_thigh' in ' '.join(lines)


def _with_pelvis_frames(text, frames):
    """The shipped character with frames fixed to its pelvis: {name: 'x y z'}."""
    extra = ''.join(f'<link name="{n}"/><joint name="{n}_joint" type="fixed"><parent '
                    f'link="base_link"/><child link="{n}"/><origin xyz="{xyz}"/></joint>'
                    for n, xyz in frames.items())
    return text.replace('</robot>', extra + '</robot>')


def test_a_frame_fixed_low_in_the_pelvis_gets_a_capsule_as_the_body_proxy_draws_a_bone_to_it():
    # Romeo's run: its IMU frame sits low and ahead in its shapeless pelvis; the body proxy drew
    # a bone to it and the rig's colliders had none, so the hem went 24 mm into it. Two frames
    # at one place give one capsule; a footprint on the floor is no part of the pelvis.
    frames = {'imu_gyro': '0.08 0 -0.12', 'imu_accel': '0.08 0 -0.12',
              'base_footprint': '0 0 -0.9'}
    text = _with_pelvis_frames(_text(shipped('character.urdf')), frames)
    sk, rig, lines, body = _rig_of(text)
    mine = [c for c in rig['colliders'] if c['link'] == 'base_link' and c['name'] == 'pelvis'
            and c.get('type') == 'capsule']
    assert len(mine) == 1, rig['colliders']
    assert mine[0]['a'] == [0.0, 0.0, 0.0] and mine[0]['b'] == [0.08, 0.0, -0.12]
    assert mine[0]['radius'] == pytest.approx(0.04 * body.height, abs=1e-3)
    assert not [c for c in rig['colliders'] if c['name'].startswith('pelvis_')]
    assert 'each frame fixed in the pelvis' in ' '.join(lines)


# --- a skeleton that is not Z-up: the orientation keys -------------------------------------

def _turned(text, rpy):
    """The shipped character under a new root link, turned by a fixed joint."""
    return text.replace('<link name="base_link"', '<link name="turned_root"/>'
                        '<joint name="turn" type="fixed"><parent link="turned_root"/>'
                        f'<child link="base_link"/><origin xyz="0 0 0" rpy="{rpy}"/></joint>'
                        '<link name="base_link"', 1)


def _numbers(value):
    if isinstance(value, dict):
        return [x for v in value.values() for x in _numbers(v)]
    if isinstance(value, list):
        return [x for v in value for x in _numbers(v)]
    return [float(value)] if isinstance(value, (int, float)) else []


def test_a_y_up_skeleton_gets_up_and_forward_and_the_same_numbers_in_its_links():
    z_up = _rig_of(_text(shipped('character.urdf')))[1]
    # Every link turned so its z is the root's y: a Y-up skeleton whose links follow it.
    sk, rig, lines, body = _rig_of(_turned(_text(shipped('character.urdf')), '-1.5707963 0 0'))
    assert rig['up'] == [0.0, 1.0, 0.0] and rig['forward'] == [1.0, 0.0, 0.0]
    assert 'rpy_deg' not in rig['cloth']['shape'] and 'rpy_deg' not in \
        rig['jacket_bones']['upper']
    for key in ('cloth', 'jacket_bones', 'hood'):
        assert yaml.safe_dump(rig[key]) == yaml.safe_dump(z_up[key]) or \
            np.allclose(_numbers(rig[key]), _numbers(z_up[key]), atol=2e-3)
    # The floor is the world's (REP 103's +z), whatever the body's axes: a Y-up skeleton
    # stands in that world through its world joint (issue 47 item 1).
    assert rig['colliders'][-1]['normal'] == [0.0, 0.0, 1.0] and 'world_up' not in rig
    text = to_yaml(rig, lines, 'y_up.urdf', body)
    assert text.index('up: [0.0, 1.0, 0.0]') < text.index('cloth:')


def test_links_whose_axes_are_not_the_bodys_get_rpy_deg_on_shape_upper_and_ellipsoids():
    turned = _turned(_text(shipped('character.urdf')), '0 0 1.5707963')    # faces +y now
    sk, rig, lines, body = _rig_of(turned, forward=[0, 1, 0])
    assert rig['forward'] == [0.0, 1.0, 0.0] and rig['up'] == [0.0, 0.0, 1.0]
    assert 'rpy_deg' not in rig['cloth']['shape']     # its links turned with it: nothing to turn
    assert rig['cloth']['shape']['radii'] == _rig_of(_text(shipped('character.urdf')))[1][
        'cloth']['shape']['radii']
    # Facing +x with every link's frame turned a quarter turn (its x is the body's left):
    # every frame-bound key is turned back, whether forward is given or inferred.
    for forward in ([1, 0, 0], None):
        sk, rig, lines, body = _rig_of(_frames_turned(turned), forward=forward)
        assert [round(v, 6) + 0.0 for v in body.forward] == [1.0, 0.0, 0.0]
        for turned_key in (rig['cloth']['shape'], rig['jacket_bones']['upper'],
                           rig['colliders'][0]):
            assert turned_key['rpy_deg'] == [0.0, 0.0, -90.0]


def _frames_turned(turned):
    """:func:`_turned` by a quarter turn about z, each joint's offset and axis turned back.

    The body faces +x again, while every link's frame stays turned.
    """
    def back(match):
        x, y, z = (float(v) for v in match.group(2).split())
        return f'{match.group(1)}"{y:g} {-x:g} {z:g}"'
    # The turn's own offset is zero.
    return re.sub(r'(<(?:origin|axis) xyz=)"([^"]*)"', back, turned)


def _under_new_root(text, root, rpy):
    """The skeleton under a new root link, turned by a fixed joint."""
    return text.replace(f'<link name="{root}"', '<link name="turned_root"/>'
                        '<joint name="turn" type="fixed"><parent link="turned_root"/>'
                        f'<child link="{root}"/><origin xyz="0 0 0" rpy="{rpy}"/></joint>'
                        f'<link name="{root}"', 1)


def _forward_of(text, forward=None):
    sk, rig, lines, body = _rig_of(text, forward)
    why = next(line for line in lines if line.strip().startswith('forward:'))
    return [round(float(v), 6) + 0.0 for v in body.forward], why


@pytest.mark.parametrize('urdf', ['character.urdf', 'examples/mannequin.urdf'])
def test_forward_is_inferred_from_the_named_sides_when_the_legs_end_at_the_ankle(urdf):
    text = _text(shipped(urdf))
    root = Skeleton(text).link_names[0]
    fwd, why = _forward_of(text)
    assert fwd == [1.0, 0.0, 0.0] and 'by the names' in why
    # Turned to face +y (a yaw of 90 degrees under a new root) and +z (Y-up: a roll of -90).
    assert _forward_of(_under_new_root(text, root, '0 0 1.5707963'))[0] == [0.0, 1.0, 0.0]
    assert _forward_of(_under_new_root(text, root, '0 0 3.1415926'))[0] == [-1.0, 0.0, 0.0]
    assert _forward_of(_under_new_root(text, root, '-1.5707963 0 0'))[0] == [1.0, 0.0, 0.0]
    # --forward still overrides (facing back, here), and says so; across the body it is
    # refused (test_robot_rigs: on every fetched robot).
    fwd, why = _forward_of(_under_new_root(text, root, '0 0 1.5707963'), [0, -1, 0])
    assert fwd == [0.0, -1.0, 0.0] and 'given by --forward' in why
    with pytest.raises(Refusal, match='runs across the body'):
        _forward_of(_under_new_root(text, root, '0 0 1.5707963'), [1, 0, 0])


def test_forward_is_inferred_from_the_toes_whatever_the_names(tmp_path):
    urdf = tmp_path / 'mocapbank.urdf'
    assert main(['import', fetched('test_mocapbank.bvh'), '-o', str(tmp_path / 's.mcap'),
                 '--urdf-out', str(urdf)]) == 0
    text = urdf.read_text()
    fwd, why = _forward_of(text)
    assert fwd == [1.0, 0.0, 0.0] and 'toes' in why
    turned = _under_new_root(text, Skeleton(text).link_names[0], '0 0 -1.5707963')
    assert _forward_of(turned)[0] == [0.0, -1.0, 0.0]
    # With left and right named the other way round, the toes still say where the front is.
    swapped = re.sub(r'Left|Right', lambda m: 'Right' if m.group(0) == 'Left' else 'Left', turned)
    assert _forward_of(swapped)[0] == [0.0, -1.0, 0.0]


@pytest.mark.parametrize('seed', [1, 2])
def test_forward_is_inferred_whatever_the_link_axes(seed):
    from reframe import random_rotations, root_link, rotate_urdf
    text = _text(shipped('examples/mannequin.urdf'))
    turns = random_rotations(Skeleton(text).link_names, seed)
    turned = rotate_urdf(text, turns)
    # Every link frame turned: the character's forward (+x of the old root) in the new root.
    want = turns[root_link(text)].T @ [1.0, 0.0, 0.0]
    fwd, why = _forward_of(turned)
    assert np.allclose(fwd, want, atol=1e-6) and 'by the names' in why


def test_forward_without_toes_or_named_sides_is_assumed_and_says_so():
    fwd, why = _forward_of(_renamed(_text(shipped('character.urdf'))))
    assert fwd == [1.0, 0.0, 0.0] and 'assumed' in why and '--forward' in why


def test_the_y_up_proposal_loads_and_rests_where_the_z_up_one_does():
    sk, rig, lines, body = _rig_of(_turned(_text(shipped('character.urdf')), '-1.5707963 0 0'))
    loaded = Rig(yaml.safe_load(to_yaml(rig, lines, 'y_up.urdf', body)), sk)
    z_up = Rig(yaml.safe_load(to_yaml(*_rig_of(_text(shipped('character.urdf')))[1:3], 'z.urdf',
                                      body)), load_skeleton(shipped('character.urdf')))
    # base_link sits under the new root turned -90 deg about x: p -> Rx(-90) p = (x, z, -y);
    # 1e-7 because the URDF's -1.5707963 is pi/2 only to 3e-8.
    turn = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], dtype=float)     # Rx(+90)
    assert np.allclose(loaded.rest, z_up.rest @ turn, atol=1e-7)


# --- end to end on four skeletons ----------------------------------------------------------

def _replay_twice(tmp_path, session, urdf, rig):
    from jacket_cloth_ros.recording.reader import read_messages
    outs = []
    for k in range(2):
        (tmp_path / str(k)).mkdir()
        out = tmp_path / str(k) / 'replay.mcap'
        assert main(['replay', str(session), '-o', str(out), '--urdf', str(urdf),
                     '--rig', str(rig)]) == 0
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]                                  # deterministic
    from rclpy.serialization import deserialize_message
    from tf2_msgs.msg import TFMessage
    messages, _ = read_messages(str(tmp_path / '0' / 'replay.mcap'))
    tfs = [deserialize_message(m.data, TFMessage) for m in messages if m.topic == '/tf']
    values = [[t.transform.translation.x, t.transform.translation.y, t.transform.translation.z,
               t.transform.rotation.w] for msg in tfs for t in msg.transforms]
    assert len(tfs) > 50 and np.isfinite(values).all()
    return len(tfs)


def _propose_cli(tmp_path, urdf, capsys, picture=False):
    rig = tmp_path / 'rig.yaml'
    args = ['rig', '--urdf', str(urdf), '-o', str(rig)]
    if picture:
        args += ['--picture', str(tmp_path / 'rig.png')]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert 'upper arm' in out and 'thigh' in out and 'colliders' in out
    return rig


@pytest.mark.parametrize('urdf', ['character.urdf', 'examples/mannequin.urdf'])
def test_shipped_and_mannequin_replay_a_clip_with_their_proposed_rig(tmp_path, capsys, urdf):
    urdf = shipped(urdf)
    rig = _propose_cli(tmp_path, urdf, capsys, picture=True)
    assert (tmp_path / 'rig.png').read_bytes()[:4] == b'\x89PNG'
    clip = tmp_path / 'walk.mcap'
    assert main(['motion', '--clip', 'walk', '--duration', '2', '--urdf', urdf,
                 '-o', str(clip)]) == 0
    _replay_twice(tmp_path, clip, urdf, rig)


def test_the_mocapbank_capture_replays_with_its_proposed_rig(tmp_path, capsys):
    session, urdf = tmp_path / 'mocap.mcap', tmp_path / 'mocapbank.urdf'
    assert main(['import', fetched('test_mocapbank.bvh'), '-o', str(session),
                 '--urdf-out', str(urdf)]) == 0
    rig = _propose_cli(tmp_path, urdf, capsys)
    text = rig.read_text()
    assert 'LeftShoulder' in text and 'LeftElbow' in text and 'LeftHip' in text
    _replay_twice(tmp_path, session, urdf, rig)


def test_a_public_humanoid_urdf_replays_with_its_proposed_rig(tmp_path, capsys):
    urdf = fetched('jvrc1.urdf')              # JVRC-1, jvrc_description 1.1.1 (Apache-2.0)
    rig = _propose_cli(tmp_path, urdf, capsys)
    text = rig.read_text()
    assert 'L_SHOULDER_Y_S' in text and 'R_ELBOW_P_S' in text and 'NECK_P_S' in text
    # No motion ships with it: the showcase clip moves it through the world (its own joint
    # names are not the shipped character's, so the body stands still; world motion only).
    clip = tmp_path / 'clip.mcap'
    assert main(['motion', '--clip', 'showcase', '--duration', '4', '--urdf', urdf,
                 '-o', str(clip)]) == 0
    _replay_twice(tmp_path, clip, urdf, rig)
