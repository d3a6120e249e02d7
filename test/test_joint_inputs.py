# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A robot's own JointState stream: continuous joints that wrap, values the URDF does not take."""

import math

import numpy as np

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.core.skeleton import Skeleton

STEP_NS = round(1e9 / 60)


def _on_a_turret():
    """The shipped character turned by a continuous joint under its base (a robot's turret)."""
    with open(shipped('character.urdf'), encoding='utf-8') as f:
        text = f.read()
    return Skeleton(text.replace(
        '<link name="base_link"/>', '<link name="turret"/><link name="base_link"/>'
        '<joint name="turret_yaw" type="continuous"><parent link="turret"/>'
        '<child link="base_link"/><origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '</joint>', 1))


def test_a_continuous_joint_wrapped_at_pi_moves_the_cloth_as_its_unwrapped_angle():
    # A driver reports a continuous joint within +-pi. Interpolated from 3.13 to -3.13 rad,
    # the body turned the long way round within one input and flung the hem 0.30 m (a probe);
    # the angle is now taken within half a turn of the last, as the unwrapped one would be.
    skeleton = _on_a_turret()
    assert list(skeleton.continuous) == [name == 'turret_yaw' for name in skeleton.joint_names]
    sims = [JacketSimulation(skeleton, load_rig(skeleton), load_fabric('tweed_jacket'),
                             SimParams()) for _ in range(2)]
    names = tuple(skeleton.joint_names)
    yaw = names.index('turret_yaw')
    worst = 0.0
    for k in range(90):                  # 1.5 s at 1 rad/s from 2.8 rad: past pi at 0.34 s
        angle = 2.8 + k / 60
        for sim, given in zip(sims, (angle, math.atan2(math.sin(angle), math.cos(angle)))):
            positions = np.zeros(len(names))
            positions[yaw] = given
            report = sim.process(10 ** 10 + k * STEP_NS, names, positions)
            assert report.accepted and report.reset in ('', 'first sample'), report
        worst = max(worst, np.abs(sims[0].x - sims[1].x).max())
    assert worst < 1e-6, worst


def test_a_value_the_urdf_does_not_take_is_not_looked_at():
    # An unpowered gripper's NaN on a joint the URDF does not have dropped every message
    # (a probe): the joint is ignored as the docs say, its value too. A NaN on a joint of the
    # URDF still drops the message, naming it.
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    sim = JacketSimulation(skeleton, load_rig(skeleton), load_fabric('tweed_jacket'),
                           SimParams())
    names = tuple(skeleton.joint_names) + ('gripper_finger_joint',)
    for k in range(3):
        report = sim.process(10 ** 10 + k * STEP_NS, names, [0.0] * (len(names) - 1) + [np.nan])
        assert report.accepted, report
        assert ('unknown', 'ignoring joint(s) not in the URDF: gripper_finger_joint') in \
            report.warnings, report.warnings
    positions = [0.0] * len(names)
    positions[0] = np.nan
    report = sim.process(10 ** 10 + 3 * STEP_NS, names, positions)
    assert not report.accepted
    assert report.warnings == [('nonfinite', f'non-finite position for {names[0]}: message '
                                'dropped')], report.warnings


def test_a_stream_with_no_joint_of_the_urdf_is_a_warning_while_it_comes():
    # A robot publishing its joints under a prefix (robot1/l_knee): the body stayed at its
    # zero pose, /tf went out and every diagnostics said ok (a probe). They now say it.
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.ros.cdr import JointStateContent
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.ros.values import default_values
    skeleton = load_shipped_character()
    pipeline = SessionPipeline(skeleton, load_rig(skeleton),
                               default_values(load_fabrics()['tweed_jacket']), timing=False)
    names = tuple(skeleton.joint_names)
    statuses = []
    for k, given in enumerate([tuple('robot1/' + n for n in names)] * 3 + [names] * 3):
        stamp = 10 ** 10 + k * STEP_NS
        report, outputs = pipeline.on_joint_state(
            JointStateContent(stamp, given, np.zeros(len(names))), stamp)
        assert report.accepted
        status = deserialize_message(pipeline.diagnostics_now(stamp), DiagnosticArray).status[0]
        statuses.append((status.level, status.message))
    said = 'no name of the JointState is a joint of the URDF (robot1/'
    assert all(level == b'\x01' and said in text for level, text in statuses[:3]), statuses
    assert all(level == b'\x00' for level, _ in statuses[3:]), statuses


def test_a_body_under_the_floor_is_said_once_and_warned_while_it_stays():
    # A capture sunk through the floor (a wrong scale, a floor 65 cm off): the floor held the
    # cloth against the legs while every figure read clean and nothing was said (a probe).
    # Found under the floor at two looks in a row (half a second of stamps apart), it is now
    # said once, and diagnostics WARN while it stays.
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.inputs import WORLD_VARIABLES, standing_root
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.ros.cdr import JointStateContent
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.ros.values import default_values
    skeleton = load_shipped_character()
    pipeline = SessionPipeline(skeleton, load_rig(skeleton),
                               default_values(load_fabrics()['tweed_jacket']), timing=False)
    standing = float(standing_root(skeleton, [0.0, 0.0, 1.0], 0.0)[2, 3])
    names = tuple(skeleton.joint_names) + tuple(f'world_joint/{v}' for v in WORLD_VARIABLES)
    said, statuses = [], []
    for k in range(180):                # 1.5 s sunk 0.3 m, then 1.5 s standing on the floor
        stamp = 10 ** 10 + k * STEP_NS
        height = standing - (0.3 if k < 90 else 0.0)
        positions = [0.0] * len(skeleton.joint_names) + [0.0, 0.0, height, 0.0, 0.0, 0.0, 1.0]
        report, _ = pipeline.on_joint_state(JointStateContent(stamp, names, positions), stamp)
        said += [text for code, text in report.warnings if code == 'under_floor']
        if k % 30 == 29:
            status = deserialize_message(pipeline.diagnostics_now(stamp),
                                         DiagnosticArray).status[0]
            statuses.append((status.level, status.message))
    assert len(said) == 1 and said == pipeline.sim.faults.under_floor, said
    assert said[0].startswith('the body reaches 0.3') and 'under the rig\'s floor' in said[0]
    assert [level for level, _ in statuses] == [b'\x00'] + [b'\x01'] * 2 + [b'\x00'] * 3, \
        statuses


def test_two_sources_on_one_topic_are_merged_by_name_as_robot_state_publisher_does():
    # Legs and arms from two broadcasters stamped by one control tick, or the arms 5 ms
    # behind: every arms message was dropped (a repeated stamp, a stamp gone back) and the
    # arms stayed at zero for good (a probe). Each is now taken into the pose the next
    # steps start from, publishing nothing of its own: the pose of one message with both.
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros.cdr import JointStateContent
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.ros.values import default_values
    skeleton = load_shipped_character()
    values = default_values(load_fabrics()['tweed_jacket'])
    for behind in (0, 5_000_000):
        split, whole = (SessionPipeline(skeleton, load_rig(skeleton), values, timing=False)
                        for _ in range(2))
        published = []
        for k in range(60):
            stamp = 10 ** 10 + k * STEP_NS
            names, positions = joint_state_content(skeleton.joint_names, 'arms_up', k / 60)
            arms = [i for i, n in enumerate(names) if 'shoulder' in n or 'elbow' in n]
            legs = [i for i in range(len(names)) if i not in arms]
            for part, at in ((legs, stamp), (arms, stamp - behind)):
                report, out = split.on_joint_state(JointStateContent(
                    at, tuple(names[i] for i in part), np.asarray(positions)[part]), at)
                assert report.accepted and not report.warnings[1:], report
                published += [key for key, _ in out if key == 'tf']
            whole.on_joint_state(JointStateContent(stamp, tuple(names), positions), stamp)
        assert len(published) == 60 and split.dropped == 0      # one /tf a tick
        shoulder = skeleton.joint_index['l_shoulder_roll']
        assert split.sim.last.q[shoulder] > 2.0                 # the arms up
        # Merged a step later than one message brings them: the arms lag by a step.
        assert np.abs(split.sim.x - whole.sim.x).max() < 0.01, behind       # 8 mm


def test_a_stream_stamped_zero_says_the_stamp_is_not_set():
    # A driver leaving header.stamp at 0: one input taken, every other dropped as a
    # "repeated stamp", with no word that the stamp is 0 or what to set (a probe).
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    sim = JacketSimulation(skeleton, load_rig(skeleton), load_fabric('tweed_jacket'),
                           SimParams())
    names = tuple(skeleton.joint_names)
    assert sim.process(0, names, np.zeros(len(names))).accepted
    report = sim.process(0, names, np.zeros(len(names)))
    assert not report.accepted and report.warnings == [(
        'stamp', 'repeated stamp 0 (header.stamp not set by the publisher; the steps run on '
        'the stamps): message dropped')], report.warnings
