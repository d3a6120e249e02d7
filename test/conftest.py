# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Shared fixtures. DDS traffic stays on this machine and in a domain of this test run."""

import errno
import os
import signal

import numpy as np
import pytest

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
# A shell's background job (`make test &`) starts with SIGINT ignored, and every process a test
# starts inherits that: `ros2 launch` then never stopped on the tests' Ctrl-C.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
# Every call of a kernel typed once (compiled.FixedTypes) is checked against those types.
os.environ['JACKET_CLOTH_CHECK_TYPES'] = '1'


def _domain_band() -> int:
    """Return the first of 17 DDS domains of our own, in 20 to 223.

    One band per test run and per worker of it (pytest -n), so a demo, another run on the
    machine or the other worker does not cross talk: tests add 0 to 12, the lab's live
    parts take 13 to 16 (jacket_cloth_lab.lab_domain).
    """
    run = os.environ.get('PYTEST_XDIST_TESTRUNUID')
    key = int(run[:8], 16) if run else os.getpid()
    worker = int(os.environ.get('PYTEST_XDIST_WORKER', 'gw0')[2:])
    return 20 + 17 * (2 * (key % 6) + worker % 2)


DOMAIN_ID = _domain_band()
os.environ['JACKET_CLOTH_LAB_DOMAIN'] = str(DOMAIN_ID + 13)

from jacket_cloth_ros.core.fabric import load_fabric  # noqa: E402
from jacket_cloth_ros.core.rig import load_rig  # noqa: E402
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams  # noqa: E402
from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf  # noqa: E402
from jacket_cloth_ros.motion.clips import joint_state_content  # noqa: E402


class FillingFile:
    """A recorder's file on a disk that fills after ``room`` bytes: what fits, then ENOSPC."""

    def __init__(self, file, room):
        self.file, self.room = file, room

    def write(self, data):
        free = self.room - self.file.tell()
        if free <= 0:
            raise OSError(errno.ENOSPC, 'No space left on device')
        return self.file.write(bytes(data)[:free])

    def __getattr__(self, name):
        return getattr(self.file, name)


@pytest.fixture(scope='session')
def urdf_text():
    return shipped_character_urdf()


@pytest.fixture(scope='session')
def skeleton(urdf_text):
    return Skeleton(urdf_text)


@pytest.fixture(scope='session')
def rig(skeleton):
    return load_rig(skeleton)


@pytest.fixture
def make_sim(skeleton, rig):
    def make(fabric='tweed_jacket', **params):
        return JacketSimulation(skeleton, rig, load_fabric(fabric), SimParams(**params))
    return make


def body(**given):
    """Return the bundles.Body of the colliders given as bundles.Colliders' fields, no others."""
    from jacket_cloth_ros.core.bundles import Colliders, floats
    from jacket_cloth_ros.core.physics.colliders import body_of
    none3 = np.zeros((0, 3))
    colliders = dict(centers=none3, axes=np.zeros((0, 3, 3)), radii=none3, capsule_a=none3,
                     capsule_b=none3, capsule_radii=np.zeros(0), plane_points=none3,
                     plane_normals=none3)
    colliders.update(given)
    return body_of(Colliders(*(floats(colliders[f]) for f in Colliders._fields)))


def clip_inputs(skeleton, clip, seconds, start_s=10.0, rate=60.0):
    """Return (stamp_ns, names, positions) of ``clip`` at ``rate`` Hz for ``seconds``.

    As the lab's ``accuracy.clip_inputs``: the product's tests do not depend on the lab.
    """
    out = []
    for k in range(int(round(seconds * rate))):
        t = k / rate
        names, pos = joint_state_content(skeleton.joint_names, clip, t)
        out.append((int(round((start_s + t) * 1e9)), names, pos))
    return out


def stepwise(sim, clip, rate, duration, start_s=10.0):
    """Feed a clip to a simulation at ``rate`` Hz, yielding each input's report."""
    for k in range(int(round(duration * rate)) + 1):
        names, pos = joint_state_content(sim.skeleton.joint_names, clip, k / rate)
        yield sim.process(int(round((start_s + k / rate) * 1e9)), names, pos)


def play(sim, clip, rate, duration, start_s=10.0):
    """Feed a whole clip; returns the reports."""
    return list(stepwise(sim, clip, rate, duration, start_s))


@pytest.fixture
def rest_input(skeleton):
    """Return JointState content of the character standing still at the world origin."""
    names, pos = joint_state_content(skeleton.joint_names, 'idle', 0.0)
    return names, np.array(pos)


def one_line_error(capsys, argv):
    """Run ``jacket_cloth argv``: it must exit 1 with one stderr line, no traceback; return it."""
    from jacket_cloth_ros.tools.cli import main
    capsys.readouterr()
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert '\n' not in err and 'Traceback' not in err, err
    return err


def signalled(proc, ready, signum, timeout=120.0):
    """Send ``signum`` to ``proc`` once ``ready()`` returns; return its stderr once it has ended.

    A process still running when this returns or raises (``ready`` failed) is killed.
    """
    try:
        ready()
        proc.send_signal(signum)
        return proc.communicate(timeout=timeout)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.fixture
def harness():
    """Make node harnesses (test_node.Harness: a node and a peer over real DDS), closed after."""
    from test_node import Harness        # test_node imports this module: import when used
    made = []

    def make(**params):
        made.append(Harness(**params))
        return made[-1]
    yield make
    for h in made:
        h.close()


# Test files with nodes over DDS or live processes: under `pytest -n` (make test) they run one
# after another on one worker, as they do alone, and the rest of the suite on the other.
LIVE_FILES = ('test_crowd_processes.py', 'test_first_start.py', 'test_fuzz.py',
              'test_lab_speed.py', 'test_node.py', 'test_node_clock.py', 'test_node_crowd.py',
              'test_node_namespaces.py', 'test_node_viewer.py', 'test_ros2_cli.py',
              'test_tools.py')


@pytest.hookimpl(tryfirst=True)      # before xdist reads the groups
def pytest_collection_modifyitems(config, items):
    """Put the live files' tests in one xdist group (``--dist loadgroup``)."""
    for item in items:
        if item.path.name in LIVE_FILES:
            item.add_marker(pytest.mark.xdist_group('live'))
