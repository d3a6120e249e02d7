# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
r"""Launch a crowd split over K jacket_cloth_crowd processes, each taking a slice of the file.

Example::

    ros2 launch jacket_cloth_ros jacket_cloth_crowd.launch.py characters:=crowd.yaml \\
        processes:=4 threads:=2

``characters`` is a path, else (a bare name not found from the current folder) a file of the
shipped config folder, as ``crowd.yaml``.

Every process reads the same characters file and runs its slice (slice_index of
slice_count, contiguous and near-equal, ros/characters.py crowd_slice); together they run
each character once. Across machines, launch this file on each with the same characters file
and ``processes``, and ``first``/``count`` choosing that machine's processes; ROS_DOMAIN_ID and
the DDS discovery settings join them (docs/crowd.md says how to size K).
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


# The package's folder: this file is in its launch/ (a checkout's launch_scripts/), the config it
# names beside it, so a launch file and its config come from one tree.
SHARE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _characters_file(given: str) -> str:
    """Return the characters file: as given, else the shipped config's of that name."""
    if os.path.exists(given):
        return os.path.abspath(given)
    shipped = os.path.join(SHARE, 'config', given)
    if not os.path.isabs(given) and os.path.isfile(shipped):
        return shipped
    raise RuntimeError(f'characters: no file {given!r} (from {os.getcwd()}, or in {shipped})')


def _whole(context, name: str, lo: int) -> int:
    """Return a launch argument as a whole number of at least ``lo``; else a line naming it."""
    text = LaunchConfiguration(name).perform(context)
    try:
        value = int(text)
    except ValueError:
        raise RuntimeError(f'{name}: {text!r} is not a whole number') from None
    if value < lo:
        raise RuntimeError(f'{name}: {value} is below {lo}')
    return value


def _processes(context):
    # Each refused in a line naming it: a slice outside the K launched nothing, with exit 0.
    total = _whole(context, 'processes', 1)
    first = _whole(context, 'first', 0)
    if first >= total:
        raise RuntimeError(f'first: {first} is not one of the {total} processes (0 to '
                           f'{total - 1})')
    count = total - first if LaunchConfiguration('count').perform(context) == '' \
        else _whole(context, 'count', 1)
    if first + count > total:
        raise RuntimeError(f'count: {count} processes from process {first} run past the '
                           f'{total} there are')
    characters = _characters_file(LaunchConfiguration('characters').perform(context))
    threads = _whole(context, 'threads', 0)
    return [Node(package='jacket_cloth_ros', executable='jacket_cloth_crowd',
                 name=f'jacket_cloth_crowd_{i}', output='screen',
                 parameters=[{'characters': characters, 'slice_index': i,
                              'slice_count': total, 'threads': threads}])
            for i in range(first, first + count)]


def generate_launch_description():
    return LaunchDescription([
        DeclareLaunchArgument('characters', description='the characters file (YAML): a path, '
                              'or the name of one in the shipped config (crowd.yaml)'),
        DeclareLaunchArgument('processes', default_value='1',
                              description='K: node processes the crowd is split over'),
        DeclareLaunchArgument('threads', default_value='0',
                              description='threads per process for the steps; 0: all cores'),
        DeclareLaunchArgument('first', default_value='0',
                              description='the first of the K processes launched here'),
        DeclareLaunchArgument('count', default_value='',
                              description='how many of them (empty: the rest)'),
        OpaqueFunction(function=_processes),
    ])
