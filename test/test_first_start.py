# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""First start in seconds: `jacket_cloth warm` (run by make, or once after colcon build) leaves
numba's cache holding every kernel the node's per-input path calls."""

import os
import signal
import subprocess
import sys

import pytest
from conftest import DOMAIN_ID, signalled

# In a fresh process on the cache `warm` filled: the node's pipeline on the shipped character,
# every output of a few inputs, then every kernel's compile misses counted.
_NODE_PATH = '''
import sys
from numba.core.registry import CPUDispatcher
from jacket_cloth_ros.ros.warm import kernels_cached
assert kernels_cached(), 'the cache is empty'
from jacket_cloth_ros.ros.warm import warm_kernels
warm_kernels()
import jacket_cloth_ros.core.physics.cloth, jacket_cloth_ros.core.physics.pose
import jacket_cloth_ros.core.physics.step, jacket_cloth_ros.core.physics.sampling
import jacket_cloth_ros.ros.cdr, jacket_cloth_ros.ros.marker_kernel
missed = [f'{m.__name__}.{name}' for m in list(sys.modules.values())
          if m and m.__name__.startswith('jacket_cloth_ros')
          for name, f in vars(m).items()
          if isinstance(f, CPUDispatcher) and sum(f.stats.cache_misses.values())]
print(sorted(set(missed)))
'''


def test_after_warm_the_node_path_compiles_nothing(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    empty = subprocess.run(
        [sys.executable, '-c', 'from jacket_cloth_ros.ros.warm import kernels_cached;'
         'print(kernels_cached())'], env=env, capture_output=True, text=True, timeout=120)
    assert empty.stdout.strip() == 'False', empty.stderr     # a fresh install: not cached
    warm = subprocess.run([sys.executable, '-m', 'jacket_cloth_ros', 'warm'], env=env,
                          capture_output=True, text=True, timeout=1800)
    assert warm.returncode == 0 and 'compiled and cached' in warm.stdout, warm.stderr
    after = subprocess.run([sys.executable, '-c', _NODE_PATH], env=env, capture_output=True,
                           text=True, timeout=300)
    assert after.returncode == 0, after.stderr
    assert after.stdout.strip() == '[]'                        # nothing left to compile


def test_ctrl_c_while_the_node_compiles_is_one_line_and_a_prompt_exit(tmp_path):
    # It compiled inside an executor callback: Ctrl-C shut the context down, the compile ran
    # on for half a minute and the node ended in a traceback.
    # Signalled once it says it compiles: an event, not a guess at how long imports take.
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path), ROS_DOMAIN_ID=str(DOMAIN_ID + 1))
    node = subprocess.Popen([sys.executable, '-m', 'jacket_cloth_ros.ros.node'], env=env,
                            stderr=subprocess.PIPE, text=True)
    said = node.stderr.readline()
    assert 'compiling the simulation kernels' in said, said
    node.send_signal(signal.SIGINT)
    err = said + node.communicate(timeout=120)[1]     # compiling on would take minutes more
    assert node.returncode == 130 and 'Traceback' not in err, err
    assert err.strip().splitlines()[-1] == \
        'jacket_cloth_node: stopped while compiling the kernels'


def _executable(name):
    return os.path.join(os.path.dirname(sys.executable), name)


@pytest.mark.parametrize('stop', [signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_the_node_imports_is_one_line_and_its_exit_code(stop):
    # Python imports rclpy, numpy and numba for a second or more before main runs: a Ctrl-C
    # there was a KeyboardInterrupt traceback. Signalled once numpy's library is in the
    # process (an event: its memory map), so while it imports or starts, never before the
    # entry point's handler is in.
    node = subprocess.Popen([_executable('jacket_cloth_node')],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID + 2)),
                            stderr=subprocess.PIPE, text=True)
    err = signalled(node, lambda: _wait_for_library(node.pid, '_multiarray_umath'), stop)
    assert node.returncode == 128 + stop and 'Traceback' not in err, err
    assert err.strip().splitlines() == ['jacket_cloth_node: stopped while starting'], err


def test_a_second_ctrl_c_while_the_node_stops_is_ignored():
    # ros2 launch forwards the terminal's Ctrl-C that the node got too: the second one, in the
    # node's clean-up, was a KeyboardInterrupt traceback and exit -2.
    node = subprocess.Popen([_executable('jacket_cloth_node')],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID + 3)),
                            stderr=subprocess.PIPE, text=True)
    try:
        for line in node.stderr:
            if 'from the shipped character' in line:
                break
        # Signals sent back to back may reach Python as one: keep sending until it is gone, so
        # some land while it stops.
        _signal_until_gone(node, signal.SIGINT)
        err = node.communicate(timeout=60)[1]
    finally:
        if node.poll() is None:
            node.kill()
            node.wait()
    assert node.returncode == 0 and 'Traceback' not in err, err


def _signal_until_gone(process, signum, timeout=60.0):
    """Send ``signum`` to ``process`` every few milliseconds until it has exited."""
    import time
    deadline = time.monotonic() + timeout
    while process.poll() is None:
        assert time.monotonic() < deadline, 'it did not stop'
        try:
            process.send_signal(signum)
        except ProcessLookupError:
            return
        time.sleep(0.002)


def _wait_for_library(pid, name, timeout=120.0):
    """Return once process ``pid`` has mapped a library whose path holds ``name``."""
    import time
    deadline = time.monotonic() + timeout
    while True:
        with open(f'/proc/{pid}/maps') as f:
            if name in f.read():
                return
        assert time.monotonic() < deadline, f'{name} never loaded'
        time.sleep(0.005)


def test_python_dash_m_jacket_cloth_is_guarded_from_its_start():
    # The docs and the Makefile run the tools as `python -m jacket_cloth_ros`, which went to
    # the tools' main without the entry point's guard: a Ctrl-C while it imported numpy and
    # numba was a KeyboardInterrupt traceback and exit -2.
    tool = subprocess.Popen([sys.executable, '-m', 'jacket_cloth_ros', 'warm', '--help'],
                            cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    err = signalled(tool, lambda: _wait_for_library(tool.pid, '_multiarray_umath'), signal.SIGINT)
    assert tool.returncode == 130 and 'Traceback' not in err, err
    assert err.strip().splitlines() == ['jacket_cloth: stopped while starting'], err


def test_the_demos_node_is_guarded_from_its_start(tmp_path, monkeypatch):
    # `jacket_cloth demo` ran its node with `python -m`, which imports everything before the
    # guard: a Ctrl-C then was a KeyboardInterrupt traceback.
    import argparse
    from jacket_cloth_ros.tools import cli
    started = []

    class Started(Exception):
        pass

    def popen(command, *args, **kwargs):
        started.append(command)
        raise Started
    monkeypatch.setattr(cli, 'subprocess', argparse.Namespace(Popen=popen))
    monkeypatch.setenv('ROS_DOMAIN_ID', str(DOMAIN_ID + 4))    # demo sets it for its node
    with pytest.raises(Started):
        cli.cmd_demo(argparse.Namespace(out=str(tmp_path), domain_id=DOMAIN_ID + 4,
                                        ros_args=[]))
    assert started[0][-3:-1] == ['--ros-args', '-p']
    node = subprocess.Popen(started[0][:-3],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(DOMAIN_ID + 4)),
                            stderr=subprocess.PIPE, text=True)
    err = signalled(node, lambda: _wait_for_library(node.pid, '_multiarray_umath'), signal.SIGINT)
    assert node.returncode == 130 and 'Traceback' not in err, err
    assert err.strip().splitlines() == ['jacket_cloth_node: stopped while starting'], err


def test_llvmlites_finaliser_complaint_is_dropped_only_once_a_signal_stops_the_program(
        capsys, monkeypatch):
    # Ctrl-C while numba loaded a kernel, under a CPU hog: `ros2 launch` showed llvmlite's
    # "Exception ignored in: ObjectRef.__del__" traceback as the node ended.
    from jacket_cloth_ros import signals
    monkeypatch.setattr(sys, 'unraisablehook', signals._unraisable)

    def complaint(module):
        def __del__(self):
            raise AttributeError('cut short in its making')
        __del__.__module__ = module
        ref = type('ObjectRef', (), {'__del__': __del__})()
        del ref                                     # its finaliser fails: an unraisable
        return capsys.readouterr().err
    monkeypatch.setitem(signals._now, 'phase', signals.STOPPING)
    assert complaint('llvmlite.binding.ffi') == ''
    assert 'cut short' in complaint('jacket_cloth_ros.ros.node')          # ours: shown
    monkeypatch.setitem(signals._now, 'phase', signals.RUNNING)            # not stopping
    assert 'cut short' in complaint('llvmlite.binding.ffi')


def test_a_ctrl_c_inside_an_input_stops_the_node_only_once_the_input_is_recorded(monkeypatch):
    # A Ctrl-C between an input's /tf going out and its recording left a recording without
    # that input (test_ros2_cli, under load): the node's inputs run uninterrupted.
    from jacket_cloth_ros import signals
    for key, value in (('phase', signals.RUNNING), ('held', 0), ('pending', False)):
        monkeypatch.setitem(signals._now, key, value)
    done = []
    with pytest.raises(KeyboardInterrupt):
        with signals.uninterrupted():
            with signals.uninterrupted():               # nested: held to the outer end
                signals._on_signal(signal.SIGINT, None)  # as if it came here
                done.append('published')
            done.append('recorded')
    assert done == ['published', 'recorded'] and signals._now['phase'] == signals.STOPPING
    # Outside such a block it stops at once, as Python's default does.
    monkeypatch.setitem(signals._now, 'phase', signals.RUNNING)
    with pytest.raises(KeyboardInterrupt):
        signals._on_signal(signal.SIGINT, None)
