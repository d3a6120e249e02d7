# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""jacket_cloth_crowd: many characters in one node, their steps in one compiled call.

The node is jacket_cloth_node's class (ros/node.py) with its characters from a characters
file (ros/characters.py). Each character is what a jacket_cloth_node under its namespace
would be: its own ``<name>/joint_states`` in, its bones on ``/tf`` (its frame prefix),
``<name>/jacket_cloth_node/markers``, its status on ``/diagnostics``, its own resets and
bad-input handling. What it shares is the process: one executor, one DDS participant, one
recording, one ``~/viewer`` (a camera for the whole crowd: each character's level of detail is
by its own distance to it), and one compiled call for the steps of every character with an
input (core/crowd.py), spread over the cores. Each executor wake-up, CrowdInputs takes every
queued message of the characters' subscriptions and the node processes them as one batch in
the same wake-up.
"""

import argparse
import functools
import sys

import rclpy

from .node import JacketClothNode, run
from .parameters import ros_args_problem


def main(args: list[str] | None = None) -> int:
    """Run the jacket_cloth_crowd node until it is stopped; its exit code.

    :param args: the command line with its ROS arguments; None: the process's.
    """
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='jacket_cloth_crowd',
        description='Many jacketed characters in one node: each subscribes <name>/joint_states '
        'and publishes its bones on /tf, <name>/jacket_cloth_node/markers and /diagnostics. '
        'Start with --ros-args -p characters:=crowd.yaml (see docs/crowd.md).')
    problem = ros_args_problem(argv)
    if problem:                 # rcl's own error is a traceback
        print(f'jacket_cloth_crowd: {problem}', file=sys.stderr)
        return 1
    parser.parse_args(rclpy.utilities.remove_ros_args(argv)[1:])
    return run('jacket_cloth_crowd', functools.partial(JacketClothNode, crowd=True, exiting=True),
               argv, crowd=True)


if __name__ == '__main__':
    sys.exit(main())
