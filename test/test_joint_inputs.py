# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A robot's own JointState stream: continuous joints that wrap, values the URDF does not take."""

import math

import numpy as np
import pytest

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.core.skeleton import Skeleton

STEP_NS = round(1e9 / 60)


def _on_a_turret():
    """The shipped character turned by a continuous joint under its base (a robot's turret)."""
    return Skeleton(_on_a_turret_text())


def _on_a_turret_text():
    """:func:`_on_a_turret`'s URDF."""
    with open(shipped('character.urdf'), encoding='utf-8') as f:
        text = f.read()
    return text.replace(
        '<link name="base_link"/>', '<link name="turret"/><link name="base_link"/>'
        '<joint name="turret_yaw" type="continuous"><parent link="turret"/>'
        '<child link="base_link"/><origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/>'
        '</joint>', 1)


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
    # The first input's own diagnostics went out with it: the window after it is empty.
    assert all(level == b'\x01' and said in text for level, text in statuses[1:3]), statuses
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
                # The arms are missing only until their source's first message: every legs
                # message said them missing, each other's joints (a review).
                said = [code for code, _ in report.warnings]
                assert report.accepted and said == (['missing'] if k == 0 and part is legs
                                                    else []), (k, report)
                published += [key for key, _ in out if key == 'tf']
            whole.on_joint_state(JointStateContent(stamp, tuple(names), positions), stamp)
        assert len(published) == 60 and split.dropped == 0      # one /tf a tick
        shoulder = skeleton.joint_index['l_shoulder_roll']
        assert split.sim.last.q[shoulder] > 2.0                 # the arms up
        # Merged a step later than one message brings them: the arms lag by a step.
        assert np.abs(split.sim.x - whole.sim.x).max() < 0.01, behind       # 8 mm


def test_a_source_that_stops_while_another_goes_on_is_said():
    # Legs and arms from two publishers; the arms' stops. Its joints hold their last values,
    # as robot_state_publisher holds them, and nothing said so: every input was clean.
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message
    from jacket_cloth_ros.core.fabric import load_fabrics
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.motion.clips import joint_state_content
    from jacket_cloth_ros.ros import messages
    from jacket_cloth_ros.ros.cdr import JointStateContent
    from jacket_cloth_ros.ros.pipeline import SessionPipeline
    from jacket_cloth_ros.ros.values import default_values
    skeleton = load_shipped_character()
    values = default_values(load_fabrics()['tweed_jacket'])
    split, whole = (SessionPipeline(skeleton, load_rig(skeleton), values, timing=False)
                    for _ in range(2))

    def status(pipeline, stamp):
        got = deserialize_message(pipeline.diagnostics_now(stamp), DiagnosticArray).status[0]
        return got.level, got.message
    said = []
    for k in range(240):                # both for 1 s, then the legs alone for 3 s
        stamp = 10 ** 10 + k * STEP_NS
        names, positions = joint_state_content(skeleton.joint_names, 'walk', k / 60)
        arms = [i for i, n in enumerate(names) if 'shoulder' in n or 'elbow' in n]
        legs = [i for i in range(len(names)) if i not in arms]
        for part in (legs, arms) if k < 60 else (legs,):
            split.on_joint_state(JointStateContent(
                stamp, tuple(names[i] for i in part), np.asarray(positions)[part]), stamp)
        whole.on_joint_state(JointStateContent(stamp, tuple(names), positions), stamp)
        if k in (59, 130, 239):
            said.append(status(split, stamp))
            assert status(whole, stamp) == (bytes([messages.OK]), 'ok'), k
    assert said[0] == (bytes([messages.OK]), 'ok'), said
    for level, message in said[1:]:
        assert level == bytes([messages.WARN]) and 'held at their last values, their source ' \
            'silent for' in message and 'l_shoulder' in message, message
        assert 'knee' not in message, message            # the legs' source goes on
    # Steady inputs (taken without the parser) keep their source from being silent.
    assert split.sim.steps.steady_inputs > 100 and whole.sim.steps.steady_inputs > 200


def test_a_world_pose_from_a_source_that_stopped_is_said():
    # The world pose from its own publisher, which stops: the body walks on the spot.
    from jacket_cloth_ros.core.inputs import WORLD_VARIABLES, InputParser
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    joints = tuple(skeleton.joint_names)
    world = tuple(f'world_joint/{v}' for v in WORLD_VARIABLES)
    parser = InputParser(skeleton)
    for k in range(120):
        stamp = 10 ** 10 + k * STEP_NS
        parser.parse(stamp, joints, np.zeros(len(joints)))
        if k < 30:
            parser.parse(stamp, world, [0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0])
        if k in (29, 80):
            assert parser.held(stamp, 10 ** 9) == '', k
    assert parser.held(stamp, 10 ** 9) == ('the world pose (world_joint/*) held at their '
                                           'last values, their source silent for 1.5 s of '
                                           'stamps while another goes on')


def test_a_joint_is_missing_until_some_source_gives_it():
    # The line named the joints the other source of a split topic gives, on every message
    # (a review). Now a joint is missing until some name list carries it; one that no source
    # gives is said on every message, held at zero.
    from jacket_cloth_ros.core.inputs import InputParser, InputRejected
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    names = skeleton.joint_names
    legs = tuple(n for n in names if 'knee' in n or 'hip' in n or 'ankle' in n)
    arms = tuple(n for n in names if n not in legs)
    unsent = arms[-1]
    arms = arms[:-1]
    parser = InputParser(skeleton)

    def missing(stamp, given):
        sample = parser.parse(stamp, given, np.full(len(given), 0.2))
        return [text for code, text in sample.warnings if code == 'missing']
    assert [line.split(' ')[0] for line in missing(1, legs)] == [str(len(names) - len(legs))]
    alone = [f'1 joint(s) no message has given yet, held at zero: {unsent}']
    assert missing(1, arms) == alone and missing(2, legs) == alone
    q = parser.last.q
    assert q[skeleton.joint_index[unsent]] == 0.0 and q[skeleton.joint_index[arms[0]]] == 0.2
    # A message dropped for a NaN gives nothing: its joints stay missing.
    with pytest.raises(InputRejected):
        parser.parse(3, (unsent,), [np.nan])
    assert missing(3, legs) == alone
    assert missing(4, legs + arms + (unsent,)) == [] and missing(5, legs) == []


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


def _two_source_ticks(skeleton, ticks, world_x=lambda k: 0.0):
    """(stamp, names, positions) of a body's joints and its world pose from two sources."""
    from jacket_cloth_ros.core.inputs import WORLD_VARIABLES, standing_root
    standing = float(standing_root(skeleton, [0.0, 0.0, 1.0], 0.0)[2, 3])
    joints = tuple(skeleton.joint_names)
    world = tuple(f'world_joint/{v}' for v in WORLD_VARIABLES)
    for k in range(ticks):
        stamp = 10 ** 10 + k * STEP_NS
        yield stamp, joints, np.zeros(len(joints))
        yield stamp, world, np.array([world_x(k), 0.0, standing, 0.0, 0.0, 0.0, 1.0])


def test_a_second_source_that_teleports_resets_the_cloth_as_one_message_would():
    # The world pose from its own publisher jumped 5 m: merged into the last pose unchecked,
    # the next input found no move and the steps dragged the cloth 0.4 m off (a review).
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    sim = JacketSimulation(skeleton, load_rig(skeleton), load_fabric('tweed_jacket'),
                           SimParams())
    resets = []
    for stamp, names, positions in _two_source_ticks(
            skeleton, 40, lambda k: 0.0 if k < 20 else 5.0):
        report = sim.process(stamp, names, positions)
        assert report.accepted, report
        resets += [report.reset] if report.reset else []
    assert resets == ['first sample', 'teleport: moved 5.00 m between two inputs'], resets


def test_a_recording_of_two_sources_is_analyzed_and_exported_a_frame_a_tick(tmp_path, capsys):
    # analyze counted every merged input as non-finite (no /tf of its own) and export keyed
    # each one a step later: twice the keys and a warning that the stamps went back (a review).
    import json
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
    from jacket_cloth_ros.ros.cdr import joint_state
    from jacket_cloth_ros.tools.cli import main
    skeleton = load_shipped_character()
    path = tmp_path / 'two.mcap'
    rec = SessionRecorder(str(path), exclusive=False)
    rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    for stamp, names, positions in _two_source_ticks(skeleton, 30):
        rec.write('/joint_states', joint_state(stamp, names, positions), stamp)
    rec.close()
    assert main(['analyze', str(path), '--out', str(tmp_path / 'an')]) == 0
    report = json.loads((tmp_path / 'an' / 'report.json').read_text())
    assert (report['nonfinite_count'], report['frames'], report['resets']) == (0, 30, 1), report
    capsys.readouterr()
    assert main(['export', str(path), '-o', str(tmp_path / 'two.glb')]) == 0
    out = capsys.readouterr()
    assert 'went back' not in out.err and '30 frames of 60 JointState' in out.out, out


def test_a_continuous_joint_a_mimic_follows_at_another_ratio_is_taken_as_given():
    # A head mimicking a continuous turret at half its angle: a turn unwrapped by a whole
    # turn put the head half a turn off (a review). Such a joint is not unwrapped.
    text = _on_a_turret_text().replace(
        '<joint name="head_yaw" type="revolute">',
        '<joint name="head_yaw" type="revolute"><mimic joint="turret_yaw" multiplier="0.5"/>')
    skeleton = Skeleton(text)
    assert not skeleton.continuous.any()
    assert Skeleton(_on_a_turret_text()).continuous.any()


def test_a_gripper_beside_the_body_on_one_topic_is_no_warning():
    # The last message parsed named only a gripper the URDF lacks: diagnostics just after it
    # said the body stays as it is while it walked (a review). Said only when no input of
    # the window moved a joint.
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
    body = tuple(skeleton.joint_names)
    for k in range(6):
        stamp = 10 ** 10 + k * STEP_NS
        for names in (body, ('gripper_finger_joint',)):
            pipeline.on_joint_state(JointStateContent(stamp, names, np.zeros(len(names))),
                                    stamp)
        status = deserialize_message(pipeline.diagnostics_now(stamp), DiagnosticArray).status[0]
        assert 'no name of the JointState' not in status.message, status.message


def test_a_deepmimic_root_beyond_a_million_metres_is_refused(tmp_path):
    # Only the BVH importer refused it; a DeepMimic clip took a root at 1e300 (a review).
    import json
    import pytest
    from fetched import fetched
    from jacket_cloth_ros.motion.deepmimic import ClipError, load_clip
    with open(fetched('humanoid3d_walk.txt'), encoding='utf-8') as f:
        clip = json.load(f)
    clip['Frames'][3][1] = 1e300
    bad = tmp_path / 'walk.txt'
    bad.write_text(json.dumps(clip))
    with pytest.raises(ClipError, match=r"frame 3: the root is .* m from the origin, beyond "
                                        r"the 1e\+06 m a capture's root may reach"):
        load_clip(str(bad), fetched('humanoid.urdf'))


def test_a_body_under_the_floor_through_resets_is_said_once():
    # Sunk 0.3 m with a teleport every 2 s: each reset forgot it was said, and it was said
    # again, diagnostics ok meanwhile (a review).
    from jacket_cloth_ros.core.inputs import WORLD_VARIABLES, standing_root
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    sim = JacketSimulation(skeleton, load_rig(skeleton), load_fabric('tweed_jacket'),
                           SimParams())
    standing = float(standing_root(skeleton, [0.0, 0.0, 1.0], 0.0)[2, 3])
    names = tuple(skeleton.joint_names) + tuple(f'world_joint/{v}' for v in WORLD_VARIABLES)
    resets = 0
    for k in range(360):
        x = 10.0 * (k // 120)
        report = sim.process(10 ** 10 + k * STEP_NS, names, [0.0] * len(skeleton.joint_names)
                             + [x, 0.0, standing - 0.3, 0.0, 0.0, 0.0, 1.0])
        resets += report.reset.startswith('teleport')
        assert sim.watches.floor.sunk or k < 60, k
    assert resets == 2 and len(sim.faults.under_floor) == 1, sim.faults.under_floor
