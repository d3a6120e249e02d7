# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The skeleton (URDF, forward kinematics) and the rig's validation, without ROS."""

import numpy as np
import pytest
import yaml

from jacket_cloth_ros.core.config import ConfigError, shipped
from jacket_cloth_ros.core.rig import Rig, interleaved_order, split_ellipsoid
from jacket_cloth_ros.core.physics.pose import quat_from_matrix
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.core.transforms import matrix_to_quat


def test_forward_kinematics_of_the_shipped_character(skeleton):
    q = np.zeros(len(skeleton.joint_names))
    links = skeleton.forward(q)
    foot = links[skeleton.link_index['l_foot'], :3, 3]
    assert foot == pytest.approx([0.0, 0.10, -0.91])
    # Rolling the left shoulder by +90 deg about x lifts the arm out to the left (+y).
    q[skeleton.joint_index['l_shoulder_roll']] = np.pi / 2
    hand = skeleton.forward(q)[skeleton.link_index['l_hand'], :3, 3]
    shoulder = links[skeleton.link_index['l_shoulder'], :3, 3]
    assert hand - shoulder == pytest.approx([0.0, 0.56, 0.0], abs=1e-9)


def test_prismatic_and_mimic_joints():
    urdf = '''<robot name="r"><link name="a"/><link name="b"/><link name="c"/>
      <joint name="slide" type="prismatic"><parent link="a"/><child link="b"/>
        <axis xyz="0 0 2"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>
      <joint name="follow" type="prismatic"><parent link="b"/><child link="c"/>
        <axis xyz="1 0 0"/><mimic joint="slide" multiplier="2" offset="0.1"/>
        <limit lower="0" upper="1" effort="1" velocity="1"/></joint></robot>'''
    sk = Skeleton(urdf)
    assert sk.joint_names == ['slide']
    links = sk.forward(np.array([0.5]))
    assert links[sk.link_index['c'], :3, 3] == pytest.approx([1.1, 0.0, 0.5])
    # A JointState naming the mimic joint too (JVRC-1's fingers, TALOS's grippers) was told
    # it names joints "not in the URDF" (a probe); it follows its source, as in rsp.
    from jacket_cloth_ros.core.inputs import InputParser
    sample = InputParser(sk).parse(10 ** 9, ['slide', 'follow'], [0.5, 0.9])
    assert sample.warnings == [] and sample.q.tolist() == [0.5]
    assert [c for c, _ in InputParser(sk).parse(10 ** 9, ['slide', 'x'], [0.5, 0.9]).warnings
            ] == ['unknown']


@pytest.mark.parametrize('text', ['', '<robot name="x"><link name="a"/>', 'not xml at all',
                                  '<robot name="x"><joint name="j" type="revolute"/></robot>'])
def test_malformed_urdf_is_one_clear_error(text):
    with pytest.raises(ConfigError, match='URDF'):
        Skeleton(text)


@pytest.mark.parametrize('kind,twice', [
    ('link', '<link name="neck"/>'),
    ('joint', '<joint name="head_yaw" type="fixed"><parent link="head"/><child link="x"/>'
              '</joint><link name="x"/>')])
def test_a_name_defined_twice_is_refused_as_urdfdom_refuses_it(urdf_text, kind, twice):
    # The parser kept the last of two links or joints of one name, and every tool took the
    # URDF that robot_state_publisher and RViz refuse (a hostile probe).
    name = 'neck' if kind == 'link' else 'head_yaw'
    with pytest.raises(ConfigError, match=f"{kind} '{name}' is defined twice"):
        Skeleton(urdf_text.replace('</robot>', twice + '</robot>'))


def test_a_urdf_robot_state_publisher_loads_is_loaded_and_a_refusal_says_why(urdf_text):
    # Issue 47 item 3: an empty <texture/> in a material (urdfdom skips it) was refused, and
    # the refusal stopped at the element's path: "ParseError in .../texture:" and no reason.
    textured = urdf_text.replace(
        '</robot>', '<material name="skin"><color rgba="1 1 1 1"/><texture/></material></robot>')
    textured = textured.replace('<link name="base_link"/>',
                                '<link name="base_link"><sensor/></link>', 1)
    sk = Skeleton(textured)
    assert sk.link_names == Skeleton(urdf_text).link_names
    [line] = sk.warnings
    assert "an empty <texture/> in material 'skin'" in line
    assert 'unknown element "sensor"' in line and 'ignored 2 element(s)' in line
    assert Skeleton(urdf_text).warnings == []
    broken = urdf_text.replace('</robot>', '<material name="m"><texture filename=""/>'
                               '<color/></material></robot>')
    with pytest.raises(ConfigError) as refused:
        Skeleton(broken)
    message = str(refused.value)
    assert '\n' not in message and message.endswith(')')
    assert 'color' in message and 'Required attribute not set in XML: rgba' in message


def _rig_data():
    with open(shipped('jacket_rig.yaml'), encoding='utf-8') as f:
        return yaml.safe_load(f)


@pytest.mark.parametrize('edit, message', [
    (lambda d: d['cloth'].update(cols=2), 'cloth.cols'),
    (lambda d: d['cloth'].update(pin_link='tail'), "link 'tail' is not in the URDF"),
    (lambda d: d['cloth'].update(colums=9), 'unknown key.*colums'),
    (lambda d: d['hood'].update(length='long'), 'hood.length'),
    (lambda d: d['colliders'][1].update(radii=[0.1, 0.1]), r'colliders\[1\].radii'),
    (lambda d: d.pop('hood'), 'hood: missing'),
    (lambda d: d['colliders'][0].update(type='box'), r"colliders\[0\].type: 'box' is not one of"),
    (lambda d: d['colliders'][6].update(normal=[0, 0, 0]), r'colliders\[6\].normal'),
    (lambda d: d['colliders'].append({'type': 'capsule', 'link': 'spine', 'a': [0, 0, 0],
                                      'b': [0, 0, 1]}), r'colliders\[7\].radius: missing'),
    (lambda d: d['cloth']['regions'][0].update(rows=[8, 12]), r'regions\[0\]: rows/cols'),
    (lambda d: d['jacket_bones']['sleeves'][0].update(end_link='tail'),
     r"sleeves\[0\].end_link: link 'tail'"),
    (lambda d: d['jacket_bones']['upper']['shoulder_pads'].pop('right'),
     'shoulder_pads.right: missing'),
    (lambda d: d['jacket_bones']['upper']['shoulder_pads']['left'].update(aim_link='wing'),
     "shoulder_pads.left.aim_link: link 'wing'"),
])
def test_rig_validation_names_the_bad_key(skeleton, edit, message):
    data = _rig_data()
    edit(data)
    with pytest.raises(ConfigError, match=message):
        Rig(data, skeleton)


NAN, INF = float('nan'), float('inf')


@pytest.mark.parametrize('edit, message', [
    (lambda d: d['cloth']['shape'].update(row_spacing=NAN), 'shape.row_spacing: nan is not'),
    (lambda d: d['cloth']['shape'].update(center=[0, NAN, 0]), 'shape.center:.*not finite'),
    (lambda d: d['cloth']['shape'].update(center=[0, 1e300, 0]), 'shape.center:.*outside'),
    (lambda d: d['cloth']['shape'].update(radii=[INF, 0.2]), 'shape.radii:.*not finite'),
    (lambda d: d['cloth']['shape'].update(radii=[1e-300, 0.2]), 'shape.radii:.*outside'),
    (lambda d: d['colliders'][0].update(radii=[0.1, 0.1, 1e300]), r'colliders\[0\].radii'),
    (lambda d: d['hood'].update(pivot=[INF, 0, 0]), 'hood.pivot:.*not finite'),
    (lambda d: d['hood'].update(rest_direction=[NAN, 0, 1]), 'hood.rest_direction'),
    (lambda d: d['colliders'][6].update(normal=[0, 0, INF]), r'colliders\[6\].normal'),
    (lambda d: d['cloth']['max_distance'].update(hem=NAN), 'max_distance.hem: nan'),
    (lambda d: d['cloth']['max_distance'].update(top=INF), 'max_distance.top: inf'),
    (lambda d: d['cloth'].update(regions=[{'rows': [0, 1], 'cols': [0, 1]}] * 300),
     'regions: 300 entries, at most 256'),
])
def test_rig_numbers_are_finite_and_in_range(skeleton, edit, message):
    data = _rig_data()
    edit(data)
    with pytest.raises(ConfigError, match=message):
        Rig(data, skeleton, where='rig.yaml')


@pytest.mark.parametrize('attribute, value', [
    ('xyz', '0 nan 0'), ('xyz', '0 0 inf'), ('xyz', '1e300 0 0'), ('rpy', 'nan 0 0')])
def test_urdf_origins_are_finite_and_in_range(urdf_text, attribute, value):
    from jacket_cloth_ros.core.skeleton import skeleton_from
    import re
    first = re.search(r'<origin [^>]*/>', urdf_text).group(0)
    origin = '<origin xyz="0 0 0" rpy="0 0 0"/>'.replace(
        f'{attribute}="0 0 0"', f'{attribute}="{value}"')
    with pytest.raises(ConfigError, match=r"^URDF x.urdf: joint '\w+' origin"):
        skeleton_from(urdf_text.replace(first, origin, 1), 'URDF x.urdf')


@pytest.mark.parametrize('text, message', [
    # Each alias repeats the list before it ten times: a few KB that expand beyond memory.
    ('a: &a [1, 2, 3, 4, 5, 6, 7, 8, 9, 10]\n' + ''.join(
        f'{chr(98 + k)}: &{chr(98 + k)} [{", ".join(["*" + chr(97 + k)] * 10)}]\n'
        for k in range(20)), 'aliases'),
    ('a: ' + '[' * 100000 + ']' * 100000 + '\n', 'nested deeper than 32'),
    ('a: "' + 'x' * (1 << 21) + '"\n', 'larger than'),
    ('cloth: {cols: ' + 'x' * 100000 + '}\n', r'rig.yaml.cloth.cols: expected a number'),
])
def test_a_hostile_yaml_is_a_short_error_naming_the_file(skeleton, tmp_path, text, message):
    import time
    from jacket_cloth_ros.core.rig import load_rig
    path = tmp_path / 'rig.yaml'
    path.write_text(text)
    start = time.process_time()         # CPU, which a loaded machine does not stretch
    with pytest.raises(ConfigError, match=message) as error:
        load_rig(skeleton, str(path))
    assert str(error.value).startswith(str(path)) and len(str(error.value)) < 400
    assert '\n' not in str(error.value) and time.process_time() - start < 5


def test_shipped_rig_topology(rig):
    # 9x12 grid: horizontal + vertical stretch, two diagonals, two skip-one bends.
    assert rig.n == 108
    assert len(rig.con_a) == 8 * 12 + 9 * 11 + 2 * 8 * 11 + 7 * 12 + 9 * 10
    # M13: edges are the vertices with fewer than four stretch neighbours.
    grid = rig.edge.reshape(rig.rows, rig.cols)
    assert grid[0].all() and grid[-1].all() and grid[:, 0].all() and grid[:, -1].all()
    assert not grid[1:-1, 1:-1].any()
    assert rig.free.sum() == rig.n - rig.cols


def test_constraint_order_hides_latency_and_stays_top_down(rig):
    # M5 Gauss-Seidel order: each constraint shares no vertex with the four before it, so the
    # CPU overlaps consecutive projections, and the sweep still runs from the top row down.
    pairs = list(zip(rig.con_a.tolist(), rig.con_b.tolist()))
    assert sorted(pairs) == sorted(set(pairs)) and len(pairs) == 545
    clashes = sum(bool({a, b} & {v for k in range(1, 5) for v in pairs[j - k]})
                  for j, (a, b) in enumerate(pairs) if j >= 4)
    assert clashes <= 8          # only where the last few constraints leave no choice
    top_row = np.minimum(rig.con_a, rig.con_b) // rig.cols
    assert np.all(np.diff(top_row) >= -1)
    # A chain 0-1, 1-2, 2-3: 2-3 shares nothing with 0-1 so it comes second.
    assert interleaved_order([0, 1, 2], [1, 2, 3]).tolist() == [0, 2, 1]


def test_stretched_ellipsoids_are_split(rig):
    pieces = split_ellipsoid([0, 0, 0], np.eye(3), [0.08, 0.08, 0.4])
    assert len(pieces) >= 3
    for _, _, radii in pieces:
        assert radii.max() / radii.min() <= 2.0 + 1e-9
    # Together the pieces span the original's length, and neighbours overlap.
    ends = [(c[2] - r[2], c[2] + r[2]) for c, _, r in pieces]
    assert ends[0][0] == pytest.approx(-0.4) and ends[-1][1] == pytest.approx(0.4)
    assert all(a[1] > b[0] for a, b in zip(ends, ends[1:]))
    # The shipped thighs (0.085 x 0.25) are split in two, torso and pelvis are not.
    names = [c.name for c in rig.colliders]
    assert names.count('l_thigh_0') == 1 and 'l_thigh_1' in names and 'torso_1' not in names


def test_compiled_quaternions_match_transforms(skeleton):
    # physics.pose turns the bones' frames into /tf quaternions; transforms.matrix_to_quat is
    # the numpy reference. Random link frames, plus half turns where w is zero.
    rng = np.random.default_rng(3)
    frames = [skeleton.forward(rng.uniform(-3, 3, len(skeleton.joint_names)))[:, :3, :3]
              for _ in range(20)]
    frames.append(np.array([np.diag(d) for d in ((1, -1, -1), (-1, 1, -1), (-1, -1, 1))]))
    rotations = np.concatenate(frames)
    out = np.empty((len(rotations), 4))
    for rotation, quaternion in zip(rotations, out):
        quat_from_matrix(rotation, quaternion)
    assert out == pytest.approx(matrix_to_quat(rotations), abs=1e-12)
    assert np.linalg.norm(out, axis=1) == pytest.approx(1.0)


def test_a_bone_named_as_a_link_of_the_urdf_is_refused(skeleton):
    # A URDF link named as a published bone ('hood', a BVH joint of that name) put one frame
    # on /tf with two parents, the link's and the jacket's, and every tool went on (a probe).
    from jacket_cloth_ros.core.skeleton import shipped_character_urdf
    data = yaml.safe_load(open(shipped('jacket_rig.yaml'), encoding='utf-8'))
    Rig(data, skeleton)
    urdf = shipped_character_urdf().replace(
        '</robot>', '<link name="hood"/><joint name="hood_fixed" type="fixed"><parent '
        'link="head"/><child link="hood"/></joint></robot>')
    with pytest.raises(ConfigError, match="^rig: the jacket's bone\\(s\\) 'hood' would go on "
                       "/tf under the name of a link of the URDF 'jacket_character': one frame,"
                       " two parents"):
        Rig(data, Skeleton(urdf))
