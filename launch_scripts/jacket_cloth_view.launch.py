# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The jacket on the shipped character, with a motion source and RViz, on a ROS 2 install.

    ros2 launch jacket_cloth_ros jacket_cloth_view.launch.py clip:=showcase

robot_state_publisher puts the skeleton's links on /tf from the same joint_states the node
reads; the node adds the jacket and hood bones, the world -> root transform
(publish_world_tf) and its markers; RViz opens config/view/jacket_cloth.rviz (fixed frame
world).
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    share = get_package_share_directory('jacket_cloth_ros')
    with open(os.path.join(share, 'config', 'character.urdf'), encoding='utf-8') as f:
        urdf = f.read()
    return LaunchDescription([
        DeclareLaunchArgument('clip', default_value='showcase',
                              description='built-in clip: idle, walk, run, dodge, jump, '
                                          'arms_up, turn, teleport, showcase'),
        DeclareLaunchArgument('fabric', default_value='tweed_jacket',
                              description='fabric preset: tweed_jacket, down_jacket, veil'),
        Node(package='robot_state_publisher', executable='robot_state_publisher',
             parameters=[{'robot_description': urdf}]),
        Node(package='jacket_cloth_ros', executable='jacket_cloth_node',
             name='jacket_cloth_node', output='screen',
             parameters=[os.path.join(share, 'config', 'node_params.yaml'),
                         {'fabric_preset': LaunchConfiguration('fabric'), 'publish_world_tf': True,
                          'robot_description': urdf}]),
        Node(package='jacket_cloth_ros', executable='jacket_cloth', name='motion',
             arguments=['motion', '--clip', LaunchConfiguration('clip'), '--duration', '3600']),
        Node(package='rviz2', executable='rviz2',
             arguments=['-d', os.path.join(share, 'config', 'view', 'jacket_cloth.rviz')]),
    ])
