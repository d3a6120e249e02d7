# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The floor of `jacket_cloth bench speed`: the least an rclpy node can do per JointState.

It receives the JointState stream as the real node does (raw bytes, sensor-data QoS) and
republishes one pre-built TFMessage with as many bones as the shipped rig: no simulation, no
encoding, no recording. Its CPU per message plus the bare kernel's is what the node is held to.
"""

import sys

import numpy as np
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from tf2_msgs.msg import TFMessage

from ..ros.cdr import TfTemplate

BONES = 68          # the shipped rig's bones on /tf


def main():
    rclpy.init(args=sys.argv)
    node = rclpy.create_node('jacket_cloth_floor')
    names = [f'jacket_bone_{i:02d}' for i in range(BONES)]
    identity = np.tile([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], (BONES, 1))
    data = TfTemplate(names, ['spine'] * BONES).encode(identity, 0)
    pub = node.create_publisher(TFMessage, '/tf', 100)
    node.create_subscription(JointState, 'joint_states', lambda raw: pub.publish(data),
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
