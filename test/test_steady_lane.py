# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A steady input from its JointState bytes to its /tf in one compiled call (ros/steady_lane.py).

Held to the way every other input goes (cdr.JointStateReader, then JacketSimulation.process
through SessionPipeline.on_joint_state): the same outputs to the byte, and every input that
way must take (other names, odd bytes, a refusal) left to it with nothing moved.
"""

import signal
import struct
import sys

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.stepping import NOT_STEADY
from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.ros import cdr
from jacket_cloth_ros.ros.pipeline import SessionPipeline
from jacket_cloth_ros.ros.values import default_values

STEP = 16_666_667           # 60 Hz


def _pipeline(skeleton, rig, **changes):
    """A pipeline whose ``read`` counts the inputs its reader read: all but the lane's."""
    values = default_values(load_fabrics()['tweed_jacket']).with_changes(changes)
    pipe = SessionPipeline(skeleton, rig, values, timing=False)
    read, pipe.read = pipe.reader.read, 0

    def counted(raw):
        pipe.read += 1
        return read(raw)
    pipe.reader.read = counted
    return pipe


def _rclpy_bytes(stamp_ns, names, positions, frame='', velocity=()):
    """A JointState as rclpy serialises it: velocities, a frame and its own padding."""
    msg = JointState(header=Header(stamp=Time(sec=stamp_ns // 10 ** 9,
                                              nanosec=stamp_ns % 10 ** 9), frame_id=frame),
                     name=list(names), position=[float(p) for p in positions],
                     velocity=[float(v) for v in velocity])
    return bytes(serialize_message(msg))


def test_a_steady_input_from_its_bytes_gives_the_outputs_of_the_reader_and_process(
        skeleton, rig):
    # One pipeline takes bytes (on_raw: the lane when armed), its twin the reader's content
    # with the names as a list (never armed: every input through prepare). Each case below
    # must leave the lane to the reader and process, or give their very bytes.
    lane, twin = _pipeline(skeleton, rig), _pipeline(skeleton, rig)
    names = tuple(joint_state_content(skeleton.joint_names, 'walk', 0.0)[0])
    odd = tuple(reversed(names))
    reader = cdr.JointStateReader()
    cases = {6: 'nan', 9: 'repeat', 12: 'back', 15: 'names', 18: 'short', 21: 'frame',
             24: 'velocity', 27: 'gap', 30: 'cut', 33: 'big endian', 36: 'teleport',
             39: 'negative stamp', 42: 'live change'}
    stamp, refused, x, again = 10 ** 10, 0, names.index('world_joint/trans_x'), 0
    for k in range(45):
        got, pos = joint_state_content(skeleton.joint_names, 'walk', k / 60)
        pos = np.array([dict(zip(got, pos))[n] for n in names])
        case, use, step = cases.get(k), names, STEP
        if case == 'nan':
            pos[x] = np.nan
        elif case == 'repeat':
            step = 0
        elif case == 'back':
            step = -2_000_000
        elif case == 'names':
            use, pos = odd, pos[::-1].copy()
        elif case == 'short':
            pos = pos[:-1]
        elif case == 'gap':
            step = 1_500_000_000
        elif case == 'teleport':
            pos[x] += 50.0
        elif case == 'negative stamp':
            stamp = -10 ** 10
        elif case == 'live change':         # the lane must step on the new tuning
            for pipe in (lane, twin):
                pipe.apply(pipe.values.with_changes({'fabric.damping': 0.2}))
        stamp += step
        if case in ('frame', 'velocity'):
            raw = _rclpy_bytes(stamp, use, pos, frame='odom' if case == 'frame' else '',
                               velocity=pos if case == 'velocity' else ())
        else:
            raw = cdr.joint_state(stamp, use, pos)
        if case == 'cut':
            raw = raw[:len(raw) - 12]           # the positions run past the end
        elif case == 'big endian':
            raw = b'\x00\x00' + raw[2:]         # not CDR_LE: the reader hands it to rclpy
        before = lane.sim.x.copy()
        try:
            msg = reader.read(raw)
        except ValueError:
            with pytest.raises(cdr.Undecodable):
                lane.on_raw(raw)
            assert np.array_equal(lane.sim.x, before), k     # nothing moved
            refused += 1
            continue
        last, read = lane.sim.last, lane.read
        mine, ours = lane.on_raw(raw)
        listed = cdr.JointStateContent(msg.stamp_ns, list(msg.name), msg.position)
        ref, theirs = twin.on_joint_state(listed, msg.stamp_ns)
        assert (mine.accepted, mine.reset, mine.steps, mine.warnings, mine.sweeps,
                mine.substeps, mine.max_penetration, mine.limited_vertices) == (
            ref.accepted, ref.reset, ref.steps, ref.warnings, ref.sweeps, ref.substeps,
            ref.max_penetration, ref.limited_vertices), (k, case)
        assert ours == theirs, (k, case)
        assert np.array_equal(lane.sim.x, twin.sim.x), (k, case)
        # What the next input is taken on, whichever way this one went.
        a, b = lane.sim, twin.sim
        assert (a.last.stamp_ns, a.t_sim, a.steps_total) == (
            b.last.stamp_ns, b.t_sim, b.steps_total), (k, case)
        for mine_last, their_last in ((a.last, b.last), (a.parser.last, b.parser.last)):
            assert all(np.array_equal(u, v) for u, v in zip(
                (mine_last.q, mine_last.root), (their_last.q, their_last.root))), (k, case)
        assert np.array_equal(a.bones().poses, b.bones().poses), (k, case)
        # A steady input after a steady one moves the last sample on in place, made anew
        # by none: its bookkeeping (core/simulation.py's _took_again).
        again += lane.read == read and a.last is last
    assert refused == 2                         # the cut bytes and the big-endian ones
    assert again >= 5, again         # 9 of the 18 the lane took
    # The lane took 18 of the 45: not the first two, nor a case it must leave and the one or
    # two after it that rearm, nor the inputs from the negative stamp on. rclpy's bytes (the
    # frame and velocity cases), padding left as its buffer held it, it takes as the package's.
    taken = 45 - lane.read
    assert taken == 18, taken
    assert twin.sim.steps.steady_inputs == 0


def _junk_padded(stamp_ns, names, positions, junk):
    """A JointState written field by field as CDR says, its padding filled with ``junk``.

    Serializers need not zero padding (rclpy's leaves it as its buffer held it).
    """
    def padded(buf):
        return buf + bytes([junk]) * (-(len(buf) - 4) % 4)
    buf = b'\x00\x01\x00\x00' + struct.pack('<iII', stamp_ns // 10 ** 9, stamp_ns % 10 ** 9, 1)
    buf = padded(buf + b'\x00') + struct.pack('<I', len(names))
    for name in names:
        buf = padded(buf) + struct.pack('<I', len(name) + 1) + name.encode() + b'\x00'
    buf = padded(buf) + struct.pack('<I', len(positions))
    buf += bytes([junk]) * (-(len(buf) - 4) % 8) + struct.pack(f'<{len(positions)}d', *positions)
    return buf + struct.pack('<II', 0, 0)


def test_the_lane_takes_a_name_list_whatever_its_padding_holds(skeleton, rig):
    # Each input's padding holds other junk: after the first two (the reader's, then the
    # intake's arming), the lane takes every input, with the outputs of zero-padded bytes.
    lane, twin = _pipeline(skeleton, rig), _pipeline(skeleton, rig)
    names = tuple(joint_state_content(skeleton.joint_names, 'walk', 0.0)[0])
    assert len({len(n) % 4 for n in names}) > 1         # so there is padding between them
    for k in range(12):
        got, pos = joint_state_content(skeleton.joint_names, 'walk', k / 60)
        stamp = 10 ** 10 + k * STEP
        junky = _junk_padded(stamp, names, pos, junk=0x11 * (k % 15 + 1))
        assert _reader_content(junky) == _reader_content(cdr.joint_state(stamp, names, pos))
        mine, ours = lane.on_raw(junky)
        ref, theirs = twin.on_raw(cdr.joint_state(stamp, names, pos))
        assert ours == theirs and (mine.accepted, mine.steps) == (ref.accepted, ref.steps), k
    assert lane.read == twin.read == 2
    assert lane.sim.steps.steady_inputs == 10
    assert (lane.reader.name_code == -1).any()      # the padding it passed over


def _reader_content(raw):
    """What a fresh reader reads of ``raw``: stamp, names, positions."""
    msg = cdr.JointStateReader().read(raw)
    return msg.stamp_ns, msg.name, list(msg.position)


def test_the_lane_declines_bytes_its_reader_would_not_take_with_nothing_moved(skeleton, rig):
    # Straight at steady_tf: an armed pipeline given bytes it must not read returns NOT_STEADY
    # with no state moved and no /tf, and disarms, so the reader and process say what is wrong.
    names = tuple(joint_state_content(skeleton.joint_names, 'walk', 0.0)[0])
    for bad in ('names', 'count', 'short', 'header', 'bytearray', 'view'):
        pipe = _pipeline(skeleton, rig)
        for k in range(4):
            got, pos = joint_state_content(skeleton.joint_names, 'walk', k / 60)
            pipe.on_raw(cdr.joint_state(10 ** 10 + k * STEP, names, pos))
        assert pipe.sim.steps.armed is not None
        got, pos = joint_state_content(skeleton.joint_names, 'walk', 4 / 60)
        raw = cdr.joint_state(10 ** 10 + 4 * STEP, names, pos)
        if bad == 'names':
            raw = cdr.joint_state(10 ** 10 + 4 * STEP, names[:-1] + ('other',), pos)
        elif bad == 'count':
            raw = cdr.joint_state(10 ** 10 + 4 * STEP, names, list(pos) + [0.0])
        elif bad == 'short':
            raw = raw[:15]
        elif bad == 'header':
            raw = b'\x00\x02' + raw[2:]
        elif bad == 'bytearray':        # any other buffer would type the kernel anew
            raw = bytearray(raw)
        else:
            raw = memoryview(raw)
        x, t_sim = pipe.sim.x.copy(), pipe.sim.t_sim
        status, _, tf = pipe.steady_tf(raw)
        assert (status, tf) == (NOT_STEADY, None), bad
        assert np.array_equal(pipe.sim.x, x) and pipe.sim.t_sim == t_sim, bad
        if bad in ('bytearray', 'view'):        # still armed: the reader's way steps it
            report, out = pipe.on_raw(raw)
            assert report.accepted and report.steps == 2 and out[0][0] == 'tf', bad
        else:
            assert pipe.sim.steps.armed is None, bad


def test_a_pipeline_loads_its_lane_before_its_first_input(skeleton, rig):
    # Else the first steady input after a start loaded the kernel (about 120 ms late).
    assert _pipeline(skeleton, rig)._lane._types is not None


def test_a_steady_inputs_step_cost_leaves_out_what_the_caller_did_before_its_bookkeeping(
        skeleton, rig, monkeypatch):
    # The node publishes the /tf between steady_tf and after_steady: that is not the step's
    # cost (the diagnostics' step_cost and their slow status). A clock a microsecond a reading,
    # and a second between the two calls.
    import time
    pipe = _pipeline(skeleton, rig)
    names = tuple(joint_state_content(skeleton.joint_names, 'walk', 0.0)[0])
    for k in range(4):
        got, pos = joint_state_content(skeleton.joint_names, 'walk', k / 60)
        pipe.on_raw(cdr.joint_state(10 ** 10 + k * STEP, names, pos))
    clock = [0]

    def reading():
        clock[0] += 1000
        return clock[0]
    monkeypatch.setattr(time, 'perf_counter_ns', reading)
    got, pos = joint_state_content(skeleton.joint_names, 'walk', 4 / 60)
    status, stamp, tf = pipe.steady_tf(cdr.joint_state(10 ** 10 + 4 * STEP, names, pos))
    assert tf is not None
    clock[0] += 10 ** 9                         # the publish
    report, _ = pipe.after_steady(status, stamp, tf)
    assert 0 < report.step_cost_ns < 10 ** 6, report.step_cost_ns


def test_a_second_tf_to_follow_keeps_every_input_off_the_lane(skeleton, rig):
    # publish_world_tf sends the world's /tf after the bones': the lane, which sends the bones'
    # before the input's bookkeeping, is not taken; turned off live, it is again.
    pipe = _pipeline(skeleton, rig, publish_world_tf=True)
    names = tuple(joint_state_content(skeleton.joint_names, 'walk', 0.0)[0])
    for k in range(8):
        got, pos = joint_state_content(skeleton.joint_names, 'walk', k / 60)
        _, out = pipe.on_raw(cdr.joint_state(10 ** 10 + k * STEP, names, pos))
        assert [key for key, _ in out].count('tf') == (2 if k <= 4 else 1)
        if k == 4:
            assert pipe.read == 5
            pipe.apply(pipe.values.with_changes({'publish_world_tf': False}))
    assert pipe.read < 8


def test_a_ctrl_c_inside_a_whole_function_waits_for_its_end(monkeypatch):
    # The node's JointState callback is marked whole (signals.whole): held by its code on the
    # stack, not by a block entered each input, so its path to the /tf publish stays straight.
    from jacket_cloth_ros import signals
    from jacket_cloth_ros.ros.node import JacketClothNode
    assert JacketClothNode.on_joint_states.__code__ in signals._whole
    for key, value in (('phase', signals.RUNNING), ('held', 0), ('pending', False)):
        monkeypatch.setitem(signals._now, key, value)
    done = []

    def publish():
        signals._on_signal(signal.SIGINT, sys._getframe())       # as if it came here
        done.append('published')

    @signals.whole
    def inner():
        try:
            publish()
        finally:
            signals.raise_held()        # still held: its caller is whole too
        done.append('inner ended')

    @signals.whole
    def callback():
        try:
            inner()
            done.append('recorded')
        finally:
            signals.raise_held()
    with pytest.raises(KeyboardInterrupt):
        callback()
    assert done == ['published', 'inner ended', 'recorded']
    assert signals._now['phase'] == signals.STOPPING
    # Anywhere else it stops at once.
    monkeypatch.setitem(signals._now, 'phase', signals.RUNNING)
    with pytest.raises(KeyboardInterrupt):
        signals._on_signal(signal.SIGINT, sys._getframe())


def test_a_steady_inputs_tf_goes_out_within_four_calls_of_the_callback(skeleton, monkeypatch):
    # As bench speed --only hops counts them (the node fed as its subscription feeds it): the
    # package's functions from the JointState callback to the /tf publish, and their modules.
    # The tests' type check (compiled.FixedTypes) adds a frame of its own; the node has none.
    from jacket_cloth_lab.speed.hops import FILES_AT_MOST, HOPS_AT_MOST, hop_count
    from jacket_cloth_ros.core import compiled
    monkeypatch.setattr(compiled, 'CHECK_TYPES', False)
    got = hop_count(skeleton)
    assert got['hops'] <= HOPS_AT_MOST and len(got['files']) <= FILES_AT_MOST, got
    assert got['chain'][-2:] == ['ros/pipeline.py:steady_tf', 'core/stepping.py:armed_for']


def test_the_hop_count_says_why_when_its_input_would_not_be_steady(skeleton):
    # After the first input only (the cloth reset), the next goes through prepare: counting it
    # would read as the steady path grown longer; the count says what kept it off instead.
    from jacket_cloth_lab.speed.hops import hop_count
    with pytest.raises(RuntimeError, match="would not go the steady way: intake armed False.*"
                       "the last reset 'first sample'"):
        hop_count(skeleton, warm_inputs=1)
