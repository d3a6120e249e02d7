# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Launch jacket_cloth_node with a parameter file and optional session recording.

Example::

    ros2 launch jacket_cloth_ros jacket_cloth.launch.py record:=/tmp/session.mcap
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    share = get_package_share_directory('jacket_cloth_ros')
    return LaunchDescription([
        DeclareLaunchArgument('params_file',
                              default_value=os.path.join(share, 'config', 'node_params.yaml'),
                              description='node parameters (YAML)'),
        DeclareLaunchArgument('record', default_value='',
                              description='MCAP path to record the session to; empty: off'),
        DeclareLaunchArgument('fabric', default_value='tweed_jacket',
                              description='fabric preset: tweed_jacket, down_jacket, veil'),
        Node(
            package='jacket_cloth_ros',
            executable='jacket_cloth_node',
            name='jacket_cloth_node',
            output='screen',
            parameters=[LaunchConfiguration('params_file'),
                        {'record': LaunchConfiguration('record'),
                         'fabric': LaunchConfiguration('fabric')}],
        ),
    ])
