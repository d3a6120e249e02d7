# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The node's clocks: simulated time without /clock or with a stalled one, diagnostics' rate.

The watchdog (diagnostics when no input brings them) and the robot_description fallback run on
wall time, as robot_state_publisher and diagnostic_updater do: a simulator not started or
paused must not silence the node.
"""

import time

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg

from jacket_cloth_ros.motion.clips import joint_state_content
from jacket_cloth_ros.ros import clock_watch
from test_node import Harness, _level


def _clock_publisher(h):
    pub = h.peer.create_publisher(ClockMsg, '/clock', 10)
    h.spin_until(lambda: pub.get_subscription_count() > 0)
    return pub


def _clock(sec):
    return ClockMsg(clock=Time(sec=sec))


def _on_clock(harness, sec):
    """A node on simulated time with /clock at ``sec``: (harness, /clock publisher)."""
    h = harness(use_sim_time=True, robot_description_timeout=0.2, diagnostics_rate=20.0)
    clock = _clock_publisher(h)
    clock.publish(_clock(sec))
    h.spin_until(lambda: h.node.get_clock().now().nanoseconds == sec * 10 ** 9)
    return h, clock


def test_simulated_time_without_clock_falls_back_and_keeps_diagnostics(harness, capfd,
                                                                       monkeypatch):
    # No /clock (a simulator not started): the fallback never came, nothing was logged and no
    # diagnostics went out, as both timers ran on the stopped simulated clock.
    monkeypatch.setattr(clock_watch, 'NO_CLOCK_S', 0.3)
    h = harness(use_sim_time=True, robot_description_timeout=0.2, diagnostics_rate=20.0)
    assert h.c.sim.skeleton.name == 'jacket_character'          # the shipped one
    diags = []
    h.peer.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 100)
    h.spin_until(lambda: len(diags) >= 3)
    assert _level(diags[-1].status[0]) == 0
    said = []
    h.spin_until(lambda: said.append(capfd.readouterr().err) or 'no /clock' in ''.join(said))
    lines = [x for x in ''.join(said).splitlines() if 'no /clock' in x]
    assert len(lines) == 1 and 'wall time' in lines[0], lines
    # Inputs run on their own stamps, /clock or not.
    sent = h.send_clip('walk', 60, 0.2)
    h.spin_until(lambda: len(h.tf) == sent)


def test_a_stalled_clock_drops_repeated_inputs_and_says_so(harness, capfd, monkeypatch):
    # A paused simulator: /clock stops and its JointStates repeat their stamp. Every input was
    # dropped as repeated and no diagnostics went out (docs/node.md: ERROR at the diagnostics
    # rate of wall time).
    monkeypatch.setattr(clock_watch, 'STALL_S', 0.3)
    h, clock = _on_clock(harness, 50)
    diags = []
    h.peer.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 100)
    names, pos = joint_state_content(h.c.sim.skeleton.joint_names, 'idle', 0.0)
    h.send(names, pos, 50 * 10 ** 9)
    h.spin_until(lambda: h.c.inputs == 1)
    said = []
    for _ in range(30):                         # the paused simulator goes on sending
        before = h.c.inputs
        h.send(names, pos, 50 * 10 ** 9)
        h.spin_until(lambda: h.c.inputs > before)
        said.append(capfd.readouterr().err)
    h.spin_until(lambda: any(_level(d.status[0]) == 2 and
                             'every input dropped' in d.status[0].message for d in diags))
    h.spin_until(lambda: said.append(capfd.readouterr().err) or
                 '/clock has not moved' in ''.join(said))
    # The simulator resumes: one line says so.
    clock.publish(_clock(51))
    h.spin_until(lambda: said.append(capfd.readouterr().err) or
                 '/clock moves again' in ''.join(said))
    text = ''.join(said)
    assert text.count('/clock has not moved') == 1 and text.count('/clock moves again') == 1


def test_a_clock_that_jumps_back_is_said_once(harness, capfd):
    h, clock = _on_clock(harness, 80)
    diags = []
    h.peer.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 100)
    h.spin_until(lambda: len(diags) >= 2)
    clock.publish(_clock(10))                   # a looping bag, a restarted simulator
    said = []
    h.spin_until(lambda: said.append(capfd.readouterr().err) or
                 '/clock went back' in ''.join(said))
    count = len(diags)
    h.spin_until(lambda: len(diags) >= count + 2)


def test_diagnostics_without_input_go_out_at_their_rate():
    # They went out at half of diagnostics_rate: each watchdog tick found the last ones one
    # period old, under its 1.2 periods, and waited for the next.
    h = Harness(diagnostics_rate=20.0)
    try:
        diags, ticks = [], []
        h.peer.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 100)
        h.spin_until(lambda: len(diags) >= 1)
        wall = Clock(clock_type=ClockType.STEADY_TIME)
        h.peer.create_timer(1 / 20.0, lambda: ticks.append(len(diags)), clock=wall)
        h.spin_until(lambda: len(ticks) >= 41)
        published = ticks[-1] - ticks[0]            # over 40 periods of the peer's timer
        assert 34 <= published <= 44, published
    finally:
        h.close()


def test_the_watchdog_sends_one_diagnostics_per_tick_of_its_rate(harness, monkeypatch):
    # The same without DDS timing: ticks exactly one period apart each publish.
    from jacket_cloth_ros.ros import node as node_module
    h = harness(diagnostics_rate=2.0)
    sent = []
    monkeypatch.setattr(h.node.diagnostics, 'publish', sent.append)
    now = [time.monotonic() + 10.0]
    monkeypatch.setattr(node_module.time, 'monotonic', lambda: now[0])
    for _ in range(10):
        now[0] += 0.5
        h.node._diagnostics_watchdog()
    assert len(sent) >= 9, len(sent)


def test_a_different_urdf_after_the_fallback_is_one_line(harness, urdf_text, capfd):
    # The node fell back on the shipped character, then robot_state_publisher came up with the
    # robot's URDF: it was not heard at all, and nothing said so.
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from std_msgs.msg import String
    h = harness(robot_description_timeout=0.2, diagnostics_rate=20.0)
    assert h.c.sim.skeleton.name == 'jacket_character'
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = h.peer.create_publisher(String, '/robot_description', latched)
    said = []
    for k in range(3):                  # the same one again says nothing more
        pub.publish(String(data=urdf_text.replace('jacket_character', 'the_robot')))
        h.spin_until(lambda: h.node.received['robot_description'] == k + 1)
        said.append(capfd.readouterr().err)
    lines = [x for x in ''.join(said).splitlines() if 'different URDF' in x]
    assert len(lines) == 1 and 'shipped character' in lines[0] and 'restart' in lines[0], lines
    # The diagnostics say it while it holds: one log line was all a user had (a probe).
    assert _status(h) == (b'\x01', lines[0].split(']: ', 1)[-1]), (_status(h), lines[0])
    pub.publish(String(data=urdf_text))             # the one it runs: nothing to say
    h.spin_until(lambda: h.node.received['robot_description'] == 4)
    assert 'different URDF' not in capfd.readouterr().err
    assert _status(h)[0] == b'\x00', _status(h)
    assert h.c.sim.skeleton.name == 'jacket_character'
    # One that does not load is said so, not given the restart a restart would refuse.
    pub.publish(String(data=urdf_text.replace('</robot>', '')))
    h.spin_until(lambda: h.node.received['robot_description'] == 5)
    lines = [x for x in capfd.readouterr().err.splitlines() if 'URDF' in x]
    assert len(lines) == 1 and 'a URDF that does not load came on /robot_description (URDF: ' \
        'malformed robot description' in lines[0] and 'restart' not in lines[0], lines


def _status(h):
    """The level and message of the character's diagnostics now."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message
    status = deserialize_message(h.c.pipeline.diagnostics_now(0), DiagnosticArray).status[0]
    return status.level, status.message


def test_a_recording_replaced_by_another_writer_is_said_and_saved(harness, tmp_path, capfd):
    # Another process moved its own file over the recording: the node wrote on into a file no
    # path named (lost at its close) and its diagnostics still said `recording: PATH`.
    import os
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from jacket_cloth_ros.recording.reader import read_messages
    path = tmp_path / 'session.mcap'
    h = harness(record=str(path), diagnostics_rate=20.0)
    h.send_clip('walk', 60, 0.2)
    other = tmp_path / 'other.mcap'
    other.write_bytes(b'not ours')
    os.replace(other, path)
    # Inputs before the node looks (straight in, no executor to run its watchdog meanwhile).
    names = h.c.sim.skeleton.joint_names
    for k in range(6):
        n, pos = joint_state_content(names, 'walk', 0.2 + k / 60)
        msg = JointState(name=list(n), position=[float(p) for p in pos])
        msg.header.stamp.sec, msg.header.stamp.nanosec = 100, 200_000_000 + k * 16_666_667
        h.node.on_joint_states([(h.c, serialize_message(msg), {})])
    h.spin_until(lambda: h.node.recording.recorder is None)
    assert path.read_bytes() == b'not ours'                  # the other's file is left alone
    saved = tmp_path / 'session.saved.mcap'
    joint_states = read_messages(str(saved), ['/joint_states'])[0]
    assert len(joint_states) == 18                           # before the replace and after
    err = capfd.readouterr().err
    lines = [x for x in err.splitlines() if 'by another process' in x]
    assert len(lines) == 1 and 'replaced' in lines[0] and str(saved) in lines[0], lines
    diags = []
    h.peer.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 100)
    h.spin_until(lambda: len(diags) >= 1)
    values = {v.key: v.value for v in diags[-1].status[0].values}
    assert values['recording'].startswith('failed: ') and 'replaced' in values['recording']


def test_an_idle_node_records_its_diagnostics_when_they_change(harness, tmp_path):
    # Without inputs the watchdog's diagnostics repeat at one stamp: an idle crowd of 500
    # recorded about a gigabyte of them an hour. Each says something new, or is not recorded.
    from jacket_cloth_ros.recording.reader import read_messages
    path = tmp_path / 'session.mcap'
    h = harness(record=str(path), diagnostics_rate=50.0)
    diags = []
    h.peer.create_subscription(DiagnosticArray, '/diagnostics', diags.append, 100)
    h.send_clip('walk', 60, 0.1)
    last = h.c.sim.last.stamp_ns
    count = len(diags)
    h.spin_until(lambda: len(diags) >= count + 20)           # idle, published at the rate
    h.node.close()
    idle = [m for m in read_messages(str(path), ['/diagnostics'])[0] if m.log_time == last]
    assert 1 <= len(idle) <= 2, len(idle)


def test_a_clock_before_1970_is_refused_not_the_nodes_end(harness, capfd):
    # rclpy's /clock callback raised on a negative second (int32 in the message), out of the
    # executor: one `ros2 topic pub /clock` ended every node on simulated time.
    h, clock = _on_clock(harness, 30)
    clock.publish(_clock(-5))
    said = []
    h.spin_until(lambda: said.append(capfd.readouterr().err) or '/clock' in ''.join(said) and
                 'refused' in ''.join(said))
    assert h.node.get_clock().now().nanoseconds == 30 * 10 ** 9
    sent = h.send_clip('walk', 60, 0.1)
    h.spin_until(lambda: len(h.tf) == sent)
