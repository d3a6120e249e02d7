# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The package as a ROS user drives it: `ros2 pkg`, `ros2 run` and `ros2 launch`.

The real ros2 command line, against the ament prefix the package is installed in (make's
.venv, or a colcon install), each node in a domain of its own, each command in a process group
of its own, stopped with SIGINT.
"""

import contextlib
import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time

import pytest
import yaml
from conftest import DOMAIN_ID

PACKAGE = 'jacket_cloth_ros'
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# The node's line once its character is loaded and joint_states is subscribed.
LOADED = "character 'jacket_character' from the shipped character"
# A first start on an empty numba cache compiles the kernels first (`jacket_cloth warm`).
START_TIMEOUT = 600


def _ros2():
    """Return the ros2 command beside this interpreter (make's .venv) or on PATH, or None."""
    here = os.path.join(os.path.dirname(sys.executable), 'ros2')
    return here if os.access(here, os.X_OK) else shutil.which('ros2')


ROS2 = _ros2()
pytestmark = pytest.mark.skipif(ROS2 is None, reason='ros2 CLI not installed')


def _launch(name):
    """``ros2 launch`` arguments for this checkout's launch file ``name``.

    By package when the installed one is this checkout's, else by path (a worktree beside the
    checkout the prefix links to).
    """
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    mine = os.path.join(ROOT, 'launch_scripts', name)
    try:
        installed = os.path.join(get_package_share_directory(PACKAGE), 'launch', name)
    except PackageNotFoundError:
        return [mine]
    return [PACKAGE, name] if os.path.realpath(installed) == os.path.realpath(mine) else [mine]


def _ros2_param(domain, *args):
    """Run ``ros2 param ...`` without the daemon (none left behind); its completed process."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    return subprocess.run([ROS2, 'param', *args, '--no-daemon', '--timeout', '60'], env=env,
                          capture_output=True, text=True, timeout=300)


class Running:
    """A ros2 command in a process group of its own, its output read line by line."""

    def __init__(self, domain, *args, cwd=None):
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED='1')
        self.proc = subprocess.Popen([ROS2, *args], env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True,
                                     start_new_session=True, cwd=cwd)
        self.lines, self.seen = queue.Queue(), []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self):
        for line in self.proc.stdout:
            self.lines.put(line)
        self.lines.put(None)

    def _next(self, deadline):
        try:
            line = self.lines.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            return None
        if line is not None:
            self.seen.append(line)
        return line

    def wait_for(self, text, timeout=START_TIMEOUT):
        """Return the first line holding ``text``; fail on exit or after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while True:
            line = self._next(deadline)
            if line is None:
                state = 'timed out' if self.proc.poll() is None else 'exited'
                raise AssertionError(f'{state} before {text!r}:\n{self.output()}')
            if text in line:
                return line

    def wait_for_all(self, texts, timeout=START_TIMEOUT):
        """Wait for a line holding each of ``texts``, in any order."""
        deadline, missing = time.monotonic() + timeout, set(texts)
        while missing:
            line = self._next(deadline)
            if line is None:
                state = 'timed out' if self.proc.poll() is None else 'exited'
                raise AssertionError(f'{state} before {sorted(missing)}:\n{self.output()}')
            missing = {t for t in missing if t not in line}

    def interrupt(self, group=True, timeout=60):
        """SIGINT to the process group (Ctrl-C), else to the command only; its exit code."""
        if group:
            os.killpg(self.proc.pid, signal.SIGINT)
        else:
            self.proc.send_signal(signal.SIGINT)
        try:
            code = self.proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            # What it printed says which process hung: launch, or the node it waits for.
            self._drain(1.0)
            raise AssertionError(f'still running {timeout} s after SIGINT:\n{self.output()}'
                                 ) from None
        self._drain(timeout)
        return code

    def _drain(self, seconds):
        """Read what the command printed until its output ends or ``seconds`` pass."""
        deadline = time.monotonic() + seconds
        while self._next(deadline) is not None:
            pass

    def output(self):
        return ''.join(self.seen)

    def close(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=60)


@pytest.fixture
def running():
    started = []

    def start(domain, *args, cwd=None):
        started.append(Running(domain, *args, cwd=cwd))
        return started[-1]
    yield start
    for r in started:
        r.close()


def test_ros2_pkg_executables_lists_the_node_and_the_tools():
    done = subprocess.run([ROS2, 'pkg', 'executables', PACKAGE], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split('\n') == [f'{PACKAGE} jacket_cloth', f'{PACKAGE} jacket_cloth_crowd',
                                       f'{PACKAGE} jacket_cloth_node', '']


def test_ros2_run_starts_the_node_which_publishes_bones_and_stops_on_ctrl_c(running):
    domain = DOMAIN_ID + 4
    node = running(domain, 'run', PACKAGE, 'jacket_cloth_node', '--ros-args', '-p',
                   'robot_description_timeout:=0.0')
    node.wait_for(LOADED)
    _send_until_bones(domain, node)
    assert node.interrupt() == 0, node.output()
    assert 'Traceback' not in node.output(), node.output()


@contextlib.contextmanager
def _peer(domain, name):
    """A node of the test's own on ``domain`` and its executor; shut down on leaving."""
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor

    ctx = Context()
    rclpy.init(context=ctx, domain_id=domain)
    peer = rclpy.create_node(name, context=ctx)
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(peer)
    try:
        yield peer, ex
    finally:
        ex.shutdown()
        peer.destroy_node()
        rclpy.shutdown(context=ctx)


def _send_until_bones(domain, node):
    """Send the node JointStates until its bones come back on /tf."""
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage

    from jacket_cloth_ros.core.skeleton import load_shipped_character
    from jacket_cloth_ros.motion.clips import joint_state_content

    names, pos = joint_state_content(load_shipped_character().joint_names, 'idle', 0.0)
    with _peer(domain, 'ros2_run_peer') as (peer, ex):
        frames = set()
        peer.create_subscription(TFMessage, '/tf', lambda m: frames.update(
            t.child_frame_id for t in m.transforms), 100)
        pub = peer.create_publisher(JointState, 'joint_states', 10)
        deadline = time.monotonic() + 60
        k = 0
        while 'hood' not in frames:       # best effort input: send until bones come back
            assert time.monotonic() < deadline, f'no bones on /tf:\n{node.output()}'
            if pub.get_subscription_count():
                msg = JointState(name=list(names), position=[float(p) for p in pos])
                msg.header.stamp.sec, msg.header.stamp.nanosec = 100, k * 10_000_000
                pub.publish(msg)
                k += 1
            ex.spin_once(timeout_sec=0.05)


def _heard_diagnostics(domain, launch):
    """Wait for a DiagnosticArray on /diagnostics: the launched node is up, its start said.

    Why before a SIGINT to ``ros2 launch``: launch's own Ctrl-C handling hung twice when the
    signal landed while it was handling a child's line (its warning printed, its Shutdown
    never processed, no signal sent on), a race in launch, not in the node.
    """
    from diagnostic_msgs.msg import DiagnosticArray

    with _peer(domain, 'launch_peer') as (peer, ex):
        heard = []
        peer.create_subscription(DiagnosticArray, '/diagnostics', heard.append, 10)
        deadline = time.monotonic() + 60
        while not heard:
            assert time.monotonic() < deadline, f'no diagnostics:\n{launch.output()}'
            ex.spin_once(timeout_sec=0.1)


def test_ros2_launch_starts_the_node_and_stops_it_on_ctrl_c(running):
    # frame_prefix:=123 is the text "123": given as launch read it, a number, the node died on
    # its type (a hostile probe).
    launch = running(DOMAIN_ID + 5, 'launch', *_launch('jacket_cloth.launch.py'),
                     'fabric:=down_jacket', 'frame_prefix:=123')
    line = launch.wait_for(LOADED)
    assert line.startswith('[jacket_cloth_node-1]'), line
    _heard_diagnostics(DOMAIN_ID + 5, launch)
    # launch stops its nodes with a SIGINT each, as on Ctrl-C. Ctrl-C in a terminal also
    # signals the node itself: that second SIGINT can land in the node's clean-up.
    code = launch.interrupt(group=False)
    out = launch.output()
    # The node's lines, which launch prefixes with its name: launch's own interpreter may
    # print a KeyboardInterrupt it ignored in a weakref callback as Ctrl-C lands.
    ours = [line for line in out.splitlines() if line.startswith('[jacket_cloth_node-1]')]
    assert code == 0 and not [line for line in ours if 'Traceback' in line], out
    assert '[jacket_cloth_node-1]: process has finished cleanly' in out, out


def test_ros2_topic_pub_once_with_default_qos_reaches_viewer_and_wind(harness):
    """Issue 34 item 5: ``ros2 topic pub --once`` without QoS flags (reliable, volatile)
    reaches the node's ~/viewer and ~/wind; a latched-only ~/viewer never matched it."""
    h = harness()
    env = dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID))       # the harness's domain
    sent = [
        ('/jacket_cloth_node/viewer', 'geometry_msgs/msg/PointStamped',
         '{header: {frame_id: world}, point: {x: 0.0, y: 100.0, z: 0.0}}',
         lambda: h.c.sim.lod.viewer is not None and list(h.c.sim.lod.viewer) == [0, 100, 0]),
        ('/jacket_cloth_node/wind', 'geometry_msgs/msg/Vector3Stamped',
         '{vector: {x: 1.0, y: 2.0, z: 3.0}}',
         lambda: h.c.sim.params.wind == (1.0, 2.0, 3.0))]
    for topic, kind, values, taken in sent:
        proc = subprocess.Popen([ROS2, 'topic', 'pub', '--once', topic, kind, values], env=env,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                start_new_session=True)
        try:
            h.spin_until(taken, timeout=120)
            out = proc.communicate(timeout=60)[0]
            assert proc.returncode == 0, out
        finally:
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=60)
    assert h.node.received['viewer'] == 1 and h.node.received['wind'] == 1


def test_ros2_param_dump_starts_a_node_in_the_same_state_with_params_file(running, tmp_path):
    domain = DOMAIN_ID + 6
    first = running(domain, 'run', PACKAGE, 'jacket_cloth_node', '--ros-args',
                    '-p', 'robot_description_timeout:=0.0', '-p', 'fabric_preset:=down_jacket',
                    '-p', 'fabric.damping:=0.2', '-p', 'wind:=[1.0, 0.0, -0.5]',
                    '-p', 'lod_distances:=[5.0, 50.0]', '-p', 'substeps:=2')
    first.wait_for(LOADED)
    dumped = _ros2_param(domain, 'dump', '/jacket_cloth_node')
    assert dumped.returncode == 0, dumped.stdout + dumped.stderr
    dump = tmp_path / 'dump.yaml'
    dump.write_text(dumped.stdout)
    values = yaml.safe_load(dumped.stdout)['/jacket_cloth_node']['ros__parameters']
    assert values['fabric_preset'] == 'down_jacket' and values['fabric']['damping'] == 0.2
    assert first.interrupt() == 0, first.output()
    again = running(domain, 'run', PACKAGE, 'jacket_cloth_node', '--ros-args',
                    '--params-file', str(dump))
    again.wait_for(LOADED)
    redumped = _ros2_param(domain, 'dump', '/jacket_cloth_node')
    assert redumped.returncode == 0, redumped.stdout + redumped.stderr
    assert yaml.safe_load(redumped.stdout) == yaml.safe_load(dumped.stdout)
    assert again.interrupt() == 0, again.output()


def test_ros2_param_load_of_the_shipped_file_keeps_a_recording_going(running, tmp_path):
    from jacket_cloth_ros.recording.reader import read_messages
    domain = DOMAIN_ID + 7
    session = tmp_path / 'session.mcap'
    node = running(domain, 'run', PACKAGE, 'jacket_cloth_node', '--ros-args',
                   '-p', 'robot_description_timeout:=0.0', '-p', f'record:={session}')
    node.wait_for(LOADED)
    loaded = _ros2_param(domain, 'load', '/jacket_cloth_node',
                         os.path.join(ROOT, 'config', 'node_params.yaml'))
    out = loaded.stdout + loaded.stderr
    assert loaded.returncode == 0 and 'failed' not in out.lower(), out
    assert 'Set parameter sim_rate successful' in out, out
    _send_until_bones(domain, node)        # inputs after the load only
    assert node.interrupt() == 0, node.output()
    assert 'recording closed' not in node.output(), node.output()
    msgs, complete = read_messages(str(session))
    assert complete and any(m.topic == '/joint_states' for m in msgs)


def test_a_params_file_with_the_old_preset_name_is_one_line_and_exit_1(running, tmp_path):
    old = tmp_path / 'old.yaml'
    old.write_text('/**:\n  ros__parameters:\n    fabric: down_jacket\n')
    node = running(DOMAIN_ID + 8, 'run', PACKAGE, 'jacket_cloth_node', '--ros-args',
                   '--params-file', str(old))
    line = node.wait_for('jacket_cloth_node: parameter')
    assert line.strip() == ('jacket_cloth_node: parameter fabric: renamed fabric_preset (set '
                            'fabric_preset instead)'), node.output()
    assert node.proc.wait(timeout=120) == 1 and 'Traceback' not in node.output()


def test_motion_takes_ros_args_a_namespace_and_a_node_name(running):
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    domain = DOMAIN_ID + 9
    motion = running(domain, 'run', PACKAGE, 'jacket_cloth', 'motion', '--clip', 'walk',
                     '--duration', '3600', '--wait', '0', '--ros-args', '-r', '__ns:=/npc1',
                     '-r', '__node:=motion')
    got = {'joint_states': 0, 'robot_description': 0}

    def count(key):
        return lambda msg: got.__setitem__(key, got[key] + 1)
    with _peer(domain, 'motion_peer') as (peer, ex):
        peer.create_subscription(JointState, '/npc1/joint_states', count('joint_states'), 10)
        peer.create_subscription(
            String, '/npc1/robot_description', count('robot_description'),
            QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        deadline = time.monotonic() + START_TIMEOUT
        while not (all(got.values()) and
                   ('motion', '/npc1') in peer.get_node_names_and_namespaces()):
            assert motion.proc.poll() is None, motion.output()
            assert time.monotonic() < deadline, f'{got}:\n{motion.output()}'
            ex.spin_once(timeout_sec=0.05)
    motion.interrupt()
    assert 'Traceback' not in motion.output(), motion.output()


@pytest.mark.parametrize('launch_file, arguments, line', [
    ('jacket_cloth_crowd.launch.py', ['processes:=0'], 'processes: 0 is below 1'),
    ('jacket_cloth_crowd.launch.py', ['processes:=2', 'first:=1', 'count:=2'],
     'count: 2 processes from process 1 run past the 2 there are'),
    ('jacket_cloth_crowd.launch.py', ['threads:=x'], "threads: 'x' is not a whole number"),
    ('jacket_cloth.launch.py', ['params_file:=/no/such/params.yaml'],
     "params_file: no file '/no/such/params.yaml'")])
def test_a_launch_argument_that_cannot_be_is_refused_naming_it(running, launch_file,
                                                               arguments, line):
    # A slice outside the processes launched nothing with exit 0; a missing params file was a
    # warning and the node ran on its defaults (a hostile probe).
    args = ['characters:=crowd.yaml'] if 'crowd' in launch_file else []
    launch = running(DOMAIN_ID + 12, 'launch', *_launch(launch_file), *args, *arguments)
    code = launch.proc.wait(timeout=START_TIMEOUT)
    launch._drain(5.0)
    assert code != 0 and line in launch.output(), launch.output()
    assert 'process started' not in launch.output(), launch.output()


def test_the_crowd_launch_finds_a_bare_characters_name_in_the_shipped_config(running,
                                                                             tmp_path):
    launch = running(DOMAIN_ID + 10, 'launch', *_launch('jacket_cloth_crowd.launch.py'),
                     'characters:=crowd.yaml', cwd=str(tmp_path))   # no crowd.yaml here
    line = launch.wait_for('characters (slice 0 of 1)')
    assert line.startswith('[jacket_cloth_crowd-1]'), line
    _heard_diagnostics(DOMAIN_ID + 10, launch)
    assert launch.interrupt(group=False) == 0, launch.output()


def test_the_view_launch_runs_without_rviz_and_robot_state_publisher(running):
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    launch = running(DOMAIN_ID + 11, 'launch', *_launch('jacket_cloth_view.launch.py'),
                     'clip:=walk')
    expected = ["character 'jacket_character' from the robot_description parameter",
                "[motion]: playing 'walk'"]      # the motion source, named by its ROS args
    for package in ('robot_state_publisher', 'rviz2'):
        try:
            get_package_share_directory(package)
        except PackageNotFoundError:
            expected.append(f'jacket_cloth_view: {package} is not installed: running without')
    launch.wait_for_all(expected)
    _heard_diagnostics(DOMAIN_ID + 11, launch)
    assert 'process has died' not in launch.output(), launch.output()
    launch.interrupt(group=False)
    # Our processes' lines, which launch prefixes with their names: launch's own interpreter
    # may print a KeyboardInterrupt it ignored in a weakref callback as Ctrl-C lands.
    ours = [line for line in launch.output().splitlines() if line.startswith('[jacket_cloth')]
    assert not [line for line in ours if 'Traceback' in line], launch.output()
