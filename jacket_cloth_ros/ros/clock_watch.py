# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What the node says about simulated time: no /clock, a stalled one, one that jumps back.

With ``use_sim_time`` the node's clock is /clock's, which a simulator not started or paused
stops. The node's timers (the diagnostics watchdog, the robot_description fallback) run on wall
time whatever it is, so the node keeps working; this says, in one line each, why the stamps of
what it publishes without an input (diagnostics before the first input) stand still.
"""

from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:           # for the annotations only
    from rclpy.node import Node

# Wall seconds without any /clock, or with /clock at one time, before it is said.
NO_CLOCK_S = 5.0
STALL_S = 5.0
_BACK_S = 5.0           # at most one line per this many wall seconds about jumps back


class ClockWatch:
    """Follows the node's clock at each watchdog tick and says what a user should know.

    :param say: takes (level, line): level 'warn' or 'info'.
    """

    def __init__(self, say: Callable[[str, str], None]) -> None:
        self._say = say
        self._since = 0.0           # wall time the simulated clock has been at ``_last`` since
        self._last = None           # the simulated time last seen, ns (None: not on sim time)
        self._told = ''             # 'none' or 'stalled' while that is the state told
        self._back_told = -1e18

    def tick(self, wall_s: float, active: bool, clock_ns: int) -> None:
        """Look at the clock once (the watchdog's tick).

        :param wall_s: wall (monotonic) time now, s.
        :param active: whether the node is on simulated time (``use_sim_time``).
        :param clock_ns: the node's clock now, ns (0 on simulated time before any /clock).
        """
        if not active:
            self._last = None
            self._told = ''
            return
        if self._last is None or clock_ns != self._last:
            if self._last is not None:
                self._moved(wall_s, clock_ns)
            self._since, self._last = wall_s, clock_ns
            return
        waited = wall_s - self._since
        if self._told:
            return
        if clock_ns == 0 and waited >= NO_CLOCK_S:
            self._told = 'none'
            self._say('warn', f'use_sim_time is true and no /clock came in {waited:.1f} s (a '
                      'simulator not started?): the robot_description fallback and '
                      'diagnostics follow wall time, outputs their inputs\' stamps')
        elif clock_ns and waited >= STALL_S:
            self._told = 'stalled'
            self._say('warn', f'/clock has not moved for {waited:.1f} s of wall time (a '
                      'paused simulator?): inputs with a repeated stamp are dropped, '
                      'diagnostics go on at their rate of wall time')

    def _moved(self, wall_s, clock_ns):
        """Say what a move of the clock ends or is: a wait, a stall, a jump back."""
        if clock_ns < self._last and wall_s - self._back_told >= _BACK_S:
            self._back_told = wall_s
            self._say('warn', f'/clock went back by {(self._last - clock_ns) * 1e-9:.3f} s '
                      '(a restarted simulator, a looping bag): inputs keep their own stamps, '
                      'and one back by more than reset_gap resets the cloth')
        if self._told == 'stalled':
            self._say('info', f'/clock moves again, after {wall_s - self._since:.1f} s of '
                      'wall time at one time')
        elif self._told == 'none':
            self._say('info', '/clock came: the node is on simulated time')
        self._told = ''


def guard_clock(node: 'Node', warn: Callable[[str, str], None]) -> None:
    """Refuse a /clock that rclpy's time source cannot take, instead of ending the node.

    rclpy's callback raises on a negative second (the message's is an int32) out of the
    executor: one message ended every node on simulated time. Refused, the node's clock keeps
    its time and ``warn`` is told (code, line). Wrapped on the time source, so a subscription
    made later (``use_sim_time`` set live) takes the guard too.

    :param node: the node, whose rclpy time source is guarded.
    :param warn: takes (code, line), a throttled warning.
    """
    source = getattr(node, '_time_source', None)
    plain = getattr(source, 'clock_callback', None)
    if plain is None:           # another rclpy: nothing known to guard
        return

    def guarded(msg: object) -> None:
        try:
            plain(msg)
        except (ValueError, OverflowError, TypeError) as e:
            stamp = getattr(msg, 'clock', None)
            warn('clock', f'/clock {getattr(stamp, "sec", "?")} s '
                 f'{getattr(stamp, "nanosec", "?")} ns refused ({e}): the node\'s clock keeps '
                 'its time')

    source.clock_callback = guarded
    subscription = getattr(source, '_clock_sub', None)
    if subscription is not None:
        subscription.callback = guarded
