# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""sensor_msgs/JointState messages of the built-in clips, for the motion source and the lab.

sensor_msgs is imported when a message is built, so the clips and the ``jacket_cloth`` help
work without a ROS 2 install.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterator, Sequence, Tuple

from .clips import joint_state_content

if TYPE_CHECKING:           # for the annotations only: the skeleton is the caller's
    from sensor_msgs.msg import JointState
    from ..core.skeleton import Skeleton
    from .retarget import Retarget


def joint_state_message(names: Sequence[str], positions: Sequence[float],
                        stamp_ns: int) -> JointState:
    """Make a ``sensor_msgs.msg.JointState`` with these joints, stamped ``stamp_ns``.

    :param names: joint names, in the order of ``positions``.
    :param positions: one value per name (rad or m).
    :param stamp_ns: the header stamp, in nanoseconds.
    :returns: the message, header.stamp, name and position set; no velocity or effort.
    """
    from sensor_msgs.msg import JointState
    msg = JointState()
    msg.header.stamp.sec = int(stamp_ns // 1_000_000_000)
    msg.header.stamp.nanosec = int(stamp_ns % 1_000_000_000)
    msg.name = list(names)
    msg.position = [float(p) for p in positions]
    return msg


def clip_messages(skeleton: Skeleton, clip: str, rate: float, duration: float, start_ns: int,
                  world_joint: str = 'world_joint',
                  retarget: Retarget | None = None) -> Iterator[Tuple[int, object]]:
    """Yield a clip sampled at ``rate`` Hz from ``start_ns``, as JointState messages.

    :param skeleton: the character whose joints the messages name (its ``joint_names``).
    :param clip: a name of ``clips.ALL_CLIPS``.
    :param rate: messages per second (Hz).
    :param duration: seconds; longer than the clip, the clip goes on from where each loop
        ended (``clips.looped_pose``: no teleport back).
    :param start_ns: the first message's stamp, in nanoseconds.
    :param world_joint: the prefix of the root's variables (``world_joint/trans_x`` ...).
    :param retarget: the clip retargeted onto ``skeleton`` (motion.retarget), or None for a
        skeleton with the shipped character's joints.
    :returns: (the stamp in nanoseconds, the JointState) each, from ``start_ns`` to
        ``start_ns + duration`` inclusive.
    """
    n = int(round(duration * rate))
    for k in range(n + 1):
        t = k / rate
        if retarget is not None:
            names, pos = retarget.content(clip, t, world_joint)
        else:
            names, pos = joint_state_content(skeleton.joint_names, clip, t, world_joint,
                                             looped=True)
        stamp = start_ns + int(round(t * 1e9))
        yield stamp, joint_state_message(names, pos, stamp)
