# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The floor of `jacket_cloth_lab bench speed`: the least an rclpy node can do per JointState.

It receives the JointState stream as the real node does (raw bytes, sensor-data QoS) and
republishes one pre-built TFMessage with as many bones as the shipped rig: no simulation, no
encoding, no recording. Its CPU per message plus the bare kernel's is what the node is held to.

With ``--kernel`` it also runs the bare kernel (one ``kernel.cloth_step`` of the shipped rig,
states captured from a walk) in each callback, so that the kernel's share of the floor is
measured as the node runs it: once per message, 8 ms apart, in this process. Called back to
back, the same step took a third to a half of that (``speed.node_vs_floor``, README).
"""

import sys

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

from jacket_cloth_ros.ros.cdr import TfTemplate

BONES = 68          # the shipped rig's bones on /tf


def kernel_stepper(steps=None):
    """Return a callable running one bare kernel step per call, cycling through ``steps``.

    ``steps`` are kernel arguments; by default the shipped rig's, captured from a walk. Each
    state moves on.
    """
    from jacket_cloth_ros.core import kernel
    from jacket_cloth_ros.core.kernel_cache import FixedTypes
    if steps is None:
        from jacket_cloth_ros.core.fabric import load_fabric
        from jacket_cloth_ros.core.rig import load_rig
        from jacket_cloth_ros.core.skeleton import load_shipped_character
        from .speed import captured_steps
        skeleton = load_shipped_character()
        steps = captured_steps(skeleton, load_rig(skeleton), load_fabric('tweed_jacket'))
    turn = [0]
    cloth_step = FixedTypes(kernel.cloth_step, check=False)  # typed once, as the simulation

    def step():
        cloth_step(*steps[turn[0] % len(steps)])
        turn[0] += 1
    return step


def main():
    with_kernel = '--kernel' in sys.argv
    rclpy.init(args=sys.argv)
    node = rclpy.create_node('jacket_cloth_floor')
    names = [f'jacket_bone_{i:02d}' for i in range(BONES)]
    identity = np.tile([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], (BONES, 1))
    data = TfTemplate(names, ['spine'] * BONES).encode(identity, 0)
    pub = node.create_publisher(TFMessage, '/tf', 100)
    step = kernel_stepper() if with_kernel else None

    def on_joint_state(raw):
        if step is not None:
            step()
        pub.publish(data)
    node.create_subscription(JointState, 'joint_states', on_joint_state,
                             qos_profile_sensor_data, raw=True)
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
