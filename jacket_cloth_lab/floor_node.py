# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The floor of `jacket_cloth_lab bench speed`: the least an rclpy node can do per JointState.

It takes the JointState stream as the real node does (the node's CrowdInputs: raw bytes,
sensor-data QoS, a batch per wake-up) and publishes, per character and message, one pre-built
TFMessage with as many bones as the shipped rig on the node's own /tf publisher: no
simulation, no encoding, no recording. Each character's latency (arrival to /tf handed to
DDS) goes out on the node's /diagnostics publisher once a second, as the node reports it, so
the benches measure this floor as they measure the node. Its CPU per message plus the bare
kernel's is what the node is held to.

With ``--kernel`` it also steps the cloth in each batch, as the node does, so that the
kernel's share of the floor is measured as the node runs it: once per message, 8 ms apart, in
this process. Alone, one bare kernel step (``cloth.cloth_step`` of the shipped rig, states
captured from a walk), as a node of one character steps it alone; called back to back, the
same step took a third to a half of that (``speed.node_vs_floor``, README).

With ``--crowd N`` it is the floor of a crowd node of N characters (jacket_cloth_crowd): N
subscriptions to /joint_states, and with ``--kernel`` their steps by the crowd's core
(``crowd_stepper``).
"""

import sys
import time
from typing import Callable, Sequence

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from jacket_cloth_ros.ros.cdr import JointStateReader, TfTemplate
from jacket_cloth_ros.ros.character import CrowdInputs
from jacket_cloth_ros.ros.node import diagnostics_publisher, tf_publisher
from jacket_cloth_ros.ros.pipeline import quantile

BONES = 68          # the shipped rig's bones on /tf


def kernel_stepper(steps: Sequence[tuple] | None = None) -> Callable[[], None]:
    """Return a callable running one bare kernel step per call, cycling through the steps.

    Each state moves on.

    :param steps: ``cloth_step``'s arguments, one tuple per step; None: the shipped rig's,
        captured from a walk.
    """
    from jacket_cloth_ros.core.compiled import FixedTypes
    from jacket_cloth_ros.core.physics import cloth
    if steps is None:
        steps = _walk_steps()
    turn = [0]
    cloth_step = FixedTypes(cloth.cloth_step, check=False)  # typed once, as the simulation

    def step():
        cloth_step(*steps[turn[0] % len(steps)])
        turn[0] += 1
    return step


def _prebuilt_tf(prefix=''):
    """Return a TFMessage's bytes with as many bones as the shipped rig, all at identity."""
    identity = np.tile([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], (BONES, 1))
    names = [f'jacket_bone_{i:02d}' for i in range(BONES)]
    return TfTemplate(names, ['spine'] * BONES, prefix).encode(identity, 0)


def floor(node: Node, n: int, with_kernel: bool) -> None:
    """Set a node up as the floor of a node of many characters (see the module's docstring).

    :param node: the node, not spinning yet.
    :param n: how many characters.
    :param with_kernel: whether each batch steps the cloth too (``--kernel``).
    """
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
    data = [_prebuilt_tf(f'f{k}/' if n > 1 else '') for k in range(n)]
    step = (_alone_stepper() if n == 1 else crowd_stepper(n)) if with_kernel else None
    tf = tf_publisher(node)
    diagnostics = diagnostics_publisher(node)
    latencies = [[] for _ in range(n)]
    inputs = [0] * n
    last = [None]                   # the last input's CDR bytes
    reader = JointStateReader()

    def on_inputs(taken):
        now = time.time_ns()
        if step is not None:
            step([k for k, _, _ in taken])
        for k, _, info in taken:
            tf.publish(data[k])
            inputs[k] += 1
            latencies[k].append(time.time_ns() - (info.get('received_timestamp') or now))
        if taken:
            last[0] = taken[-1][1]

    def report():
        if last[0] is None:
            return
        msg = DiagnosticArray()
        # Stamped as the node stamps its own: the last input's, so inputs that stop do not
        # read as inputs left unanswered.
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(
            reader.read(last[0]).stamp_ns, 10 ** 9)
        for k in range(n):
            if latencies[k]:
                p99 = quantile(sorted(latencies[k]), 0.99) * 1e-3     # as the node's
                msg.status.append(DiagnosticStatus(name=f'floor {k}', values=[
                    KeyValue(key='latency_us_p99', value=f'{p99:.1f}'),
                    KeyValue(key='inputs', value=str(inputs[k]))]))
                latencies[k] = []
        diagnostics.publish(msg)
    waitable = CrowdInputs(node.default_callback_group, on_inputs)
    for k in range(n):
        waitable.subscribe(node, k, 'joint_states')
    node.add_waitable(waitable)
    node.create_timer(1.0, report)


def _alone_stepper():
    """Return ``crowd_stepper``'s callable for one character, stepped alone by the bare kernel."""
    one = kernel_stepper()

    def step(characters):
        for _ in characters:
            one()
    return step


def crowd_stepper(n: int) -> Callable[[list[int]], None]:
    """Return a callable stepping, for a list of character indices, those characters' cloth.

    What the crowd's core does for a batch of steady inputs (``core.crowd.stepped``: the
    compiled intake, one compiled call, each simulation's completion), for shipped
    characters walking on, each input the next 1/120 s of the walk; nothing of the node.
    A character twice in the list is stepped twice, in two rounds, as the crowd does. The
    callable's ``crowd`` is its CrowdSteps.

    :param n: how many characters.
    """
    from jacket_cloth_ros.core.crowd import CrowdSteps, stepped
    from jacket_cloth_ros.core.simulation import JacketSimulation
    from .crowd import RATE, endless_walk
    skeleton, rig, fabric = _shipped()
    walk, (along, xs), loop_x = endless_walk(skeleton)
    names = tuple(walk[0].name)
    positions = [np.array(m.position, dtype=np.float64) for m in walk]
    steps = CrowdSteps(1)
    for _ in range(n):
        steps.add(JacketSimulation(skeleton, rig, fabric))
    inputs = [0] * n

    def step(characters):
        batch = []
        for k in characters:
            loop, frame = divmod(inputs[k], len(walk))
            position = positions[frame].copy()
            position[along] = xs[frame] + loop * loop_x
            batch.append((k, 10 ** 10 + round(inputs[k] * 1e9 / RATE), names, position))
            inputs[k] += 1
        stepped(steps, batch)
    step.crowd = steps
    return step


def _shipped():
    """Return the shipped character's skeleton, its rig and the tweed jacket."""
    from jacket_cloth_ros.core.fabric import load_fabric
    from jacket_cloth_ros.core.rig import load_rig
    from jacket_cloth_ros.core.skeleton import load_shipped_character
    skeleton = load_shipped_character()
    return skeleton, load_rig(skeleton), load_fabric('tweed_jacket')


def _walk_steps():
    """Return the shipped rig's kernel arguments, captured from a walk."""
    from .speed import captured_steps
    return captured_steps(*_shipped())


def main() -> int:
    """Run the floor node as ``sys.argv`` says (``--crowd N``, ``--kernel``) until stopped."""
    crowd = '--crowd' in sys.argv
    rclpy.init(args=sys.argv)
    node = rclpy.create_node('jacket_cloth_crowd_floor' if crowd else 'jacket_cloth_floor')
    floor(node, int(sys.argv[sys.argv.index('--crowd') + 1]) if crowd else 1,
          '--kernel' in sys.argv)
    return _spin(node)


def _spin(node):
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
