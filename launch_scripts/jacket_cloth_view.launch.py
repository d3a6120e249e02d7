# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The jacket on the shipped character, with a motion source and RViz, on a ROS 2 install.

    ros2 launch jacket_cloth_ros jacket_cloth_view.launch.py clip:=showcase

robot_state_publisher puts the skeleton's links on /tf from the same joint_states the node
reads; the node adds the jacket and hood bones, the world -> root transform
(publish_world_tf) and its markers; RViz opens config/view/jacket_cloth.rviz (fixed frame
world). robot_state_publisher and RViz run if installed; without them (the wheels) the node and
the motion source run alone, and the launch says which package is missing in one line each.
"""

import os

from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, LogInfo
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


# The package's folder: this file is in its launch/ (a checkout's launch_scripts/), the config it
# names beside it, so a launch file and its config come from one tree.
SHARE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _installed(package: str) -> bool:
    try:
        get_package_share_directory(package)
    except PackageNotFoundError:
        return False
    return True


def _if_installed(package: str, node: Node, without: str) -> Node | LogInfo:
    """``node``, else one line saying the package is missing and what is lost."""
    if _installed(package):
        return node
    return LogInfo(msg=f'jacket_cloth_view: {package} is not installed: running without it '
                   f'({without})')


def generate_launch_description():
    with open(os.path.join(SHARE, 'config', 'character.urdf'), encoding='utf-8') as f:
        urdf = f.read()
    rviz_config = os.path.join(SHARE, 'config', 'view', 'jacket_cloth.rviz')
    return LaunchDescription([
        DeclareLaunchArgument('clip', default_value='showcase',
                              description='built-in clip: idle, walk, run, dodge, jump, '
                                          'arms_up, turn, teleport, showcase'),
        DeclareLaunchArgument('fabric', default_value='tweed_jacket',
                              description='fabric_preset: tweed_jacket, down_jacket, veil'),
        _if_installed('robot_state_publisher',
                      Node(package='robot_state_publisher', executable='robot_state_publisher',
                           parameters=[{'robot_description': urdf}]),
                      "the skeleton's links are not on /tf"),
        Node(package='jacket_cloth_ros', executable='jacket_cloth_node',
             name='jacket_cloth_node', output='screen',
             parameters=[os.path.join(SHARE, 'config', 'node_params.yaml'),
                         {'fabric_preset': LaunchConfiguration('fabric'),
                          'publish_world_tf': True, 'robot_description': urdf}]),
        Node(package='jacket_cloth_ros', executable='jacket_cloth', name='motion',
             output='screen',
             arguments=['motion', '--clip', LaunchConfiguration('clip'), '--duration', '3600']),
        _if_installed('rviz2',
                      Node(package='rviz2', executable='rviz2',
                           arguments=['-d', rviz_config]),
                      'record with -p record:=... and open it in Foxglove'),
    ])
