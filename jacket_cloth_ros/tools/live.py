# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A live JointState source on the ROS graph: ``jacket_cloth motion`` and ``jacket_cloth play``.

One node publishes the character's URDF on ``robot_description`` (latched, relative to its
namespace as robot_state_publisher's) and JointStates on ``joint_states`` at their stamps'
pace, each stamped now plus its offset from the first, so /tf and the node's clock agree.
"""

import signal
import time
from collections.abc import Iterable
from typing import Callable

from ..ros.cdr import joint_state

ACK_WAIT_S = 5.0        # at most, for the readers to acknowledge the last input


class Stopped(BaseException):
    """SIGINT or SIGTERM asked a command to stop.

    Not an Exception, as KeyboardInterrupt is not: a reader's or parser's ``except
    Exception`` must not take it for bad input (a stopped replay said its file was damaged).
    """

    def __init__(self, signum: int) -> None:
        """Name the signal that stopped the command.

        :param signum: the signal's number.
        """
        super().__init__(f'stopped by {signal.Signals(signum).name}')
        self.signum = signum


class SourceError(Exception):
    """The source could not start (its ROS arguments); the message is one line."""


def _stop(signum, frame):
    for other in (signal.SIGINT, signal.SIGTERM):    # a second one must not cut the clean-up
        signal.signal(other, signal.SIG_IGN)
    raise Stopped(signum)


def play_live(name: str, urdf: str | None, inputs: Iterable[tuple[int, tuple, object]],
              ros_args: list[str], best_effort: bool = False, wait_s: float = 1.0,
              say: Callable[[object, str], None] | None = None) -> int:
    """Publish ``inputs`` live as JointStates; return how many were sent.

    :param name: the node's name (ROS arguments may rename it).
    :param urdf: the character's URDF text for ``robot_description``; None publishes none.
    :param inputs: ``(offset_ns, names, positions)`` in order; ``offset_ns`` from the first
        input, which is sent once a subscriber is there (or after ``wait_s``).
    :param ros_args: ``--ros-args ...`` for the node (namespace, remaps, name).
    :param best_effort: publish best effort instead of reliable.
    :param wait_s: seconds to wait for a ``joint_states`` subscriber before the first input.
    :param say: ``say(logger, line)`` before the first input and after the last.
    """
    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    # Our handlers, not rclpy's: its own shut the context down under a publish (a traceback).
    try:
        rclpy.init(args=['jacket_cloth', *ros_args],
                   signal_handler_options=rclpy.signals.SignalHandlerOptions.NO)
    except RuntimeError as e:           # rcl's RCLError: the text's first sentence is enough
        raise SourceError(f'--ros-args: {str(e).split(". Error")[0]}') from None
    previous = {s: signal.signal(s, _stop) for s in (signal.SIGINT, signal.SIGTERM)}
    node = rclpy.create_node(name)
    sent = 0
    try:
        reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
        pub = node.create_publisher(JointState, 'joint_states',
                                    QoSProfile(depth=10, reliability=reliability))
        if urdf is not None:
            latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
            node.create_publisher(String, 'robot_description', latched).publish(
                String(data=urdf))
        # The node subscribes once its character is loaded: wait for it, so the first input
        # is not lost, then give discovery a moment to settle.
        deadline = time.monotonic() + wait_s
        while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(min(0.3, wait_s))
        logger = node.get_logger()
        if say:
            say(logger, 'playing')
        start = node.get_clock().now().nanoseconds
        wall0 = time.monotonic()
        for offset_ns, names, positions in inputs:
            delay = wall0 + offset_ns * 1e-9 - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            pub.publish(joint_state(start + offset_ns, names, positions))
            sent += 1
        # A reliable writer destroyed before its readers acknowledged the last input loses
        # it (seen once: 30 of 31 heard); bounded, so a reader that went away cannot hold us.
        pub.wait_for_all_acked(Duration(seconds=ACK_WAIT_S))
        if say:
            say(logger, 'played')
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        for s, handler in previous.items():
            signal.signal(s, handler)
    return sent
