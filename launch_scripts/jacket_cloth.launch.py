# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Launch jacket_cloth_node with a parameter file and optional session recording.

Example::

    ros2 launch jacket_cloth_ros jacket_cloth.launch.py record:=/tmp/session.mcap
    ros2 launch jacket_cloth_ros jacket_cloth.launch.py namespace:=npc1 frame_prefix:=npc1/

Under a namespace the node reads that namespace's joint_states and robot_description; its
bones go to the shared /tf, kept apart by frame_prefix.
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue


# The package's folder: this file is in its launch/ (a checkout's launch_scripts/), the config it
# names beside it, so a launch file and its config come from one tree.
SHARE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument('params_file',
                              default_value=os.path.join(SHARE, 'config', 'node_params.yaml'),
                              description='node parameters (YAML)'),
        DeclareLaunchArgument('record', default_value='',
                              description='MCAP path to record the session to; empty: off'),
        DeclareLaunchArgument('fabric', default_value='tweed_jacket',
                              description='fabric_preset: tweed_jacket, down_jacket, veil'),
        DeclareLaunchArgument('namespace', default_value='',
                              description='namespace of the node (one per character)'),
        DeclareLaunchArgument('frame_prefix', default_value='',
                              description='prepended to every bone frame id, e.g. npc1/'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='use /clock (the simulation time comes from the '
                                          'JointState stamps either way)'),
        OpaqueFunction(function=_node),
    ])


def _node(context):
    # A params file that is not there was a warning, and the node ran on its defaults.
    params_file = LaunchConfiguration('params_file').perform(context)
    if not os.path.isfile(params_file):
        raise RuntimeError(f'params_file: no file {params_file!r}')

    def text(name):         # as written: frame_prefix:=123 is the text "123", not a number
        return ParameterValue(LaunchConfiguration(name), value_type=str)
    return [Node(
        package='jacket_cloth_ros',
        executable='jacket_cloth_node',
        name='jacket_cloth_node',
        namespace=LaunchConfiguration('namespace'),
        output='screen',
        parameters=[params_file,
                    {'record': text('record'),
                     'fabric_preset': text('fabric'),
                     'frame_prefix': text('frame_prefix'),
                     'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'),
                                                    value_type=bool)}],
    )]
