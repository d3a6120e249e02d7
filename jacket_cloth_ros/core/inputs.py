# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Turning one JointState's content into a skeleton sample, with every bad case named.

World motion convention (documented in the README): the character's pose in the world frame
travels in the same JointState as six-plus-one variables of a floating virtual joint, named as
MoveIt names them: ``<world_joint>/trans_x``, ``trans_y``, ``trans_z``, ``rot_x``, ``rot_y``,
``rot_z``, ``rot_w`` (the URDF root link's pose in the world frame, metres and a quaternion).
Carrying it in the JointState keeps body and world motion on one stamp, so replay is exact.
"""

import functools
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .bundles import JointSample, NamePlan, name_plan
from .physics.sampling import NON_FINITE_POSITION, ZERO_QUATERNION, fill_sample

if TYPE_CHECKING:           # for the annotations only
    from .skeleton import Skeleton

WORLD_VARIABLES = ('trans_x', 'trans_y', 'trans_z', 'rot_x', 'rot_y', 'rot_z', 'rot_w')
MAX_SOURCES = 16            # name lists whose last stamps are kept (InputParser.held)


class InputRejected(ValueError):
    """The message cannot be used at all.

    :param code: names the case, for rate-limited logging.
    :param text: the line to log.
    """

    def __init__(self, code: str, text: str):
        super().__init__(text)
        self.code = code


@dataclass(slots=True)
class Sample:
    stamp_ns: int
    q: np.ndarray            # joint values in skeleton.joint_names order
    root: np.ndarray         # 4x4 pose of the root link in the world frame
    root_quat: np.ndarray    # (x, y, z, w) of that pose, for interpolation
    warnings: list = field(default_factory=list)   # (code, text) of usable-but-odd input
    # The first world pose after messages without one: the root leaves the parser's guess.
    world_began: bool = False


def standing_root(skeleton: 'Skeleton', up: 'npt.ArrayLike', floor: float = 0.0) -> np.ndarray:
    """Return the root's world pose that stands the skeleton on a floor, unturned.

    The root goes up until the zero pose's soles (body_proxy.lowest_reach: its collision
    shapes, as the retargeted clips stand it) are at ``floor`` along ``up``; a body that
    reaches nowhere below it stays at the origin. A source that sends only the joints
    (joint_state_publisher) had a humanoid's pelvis at the origin, its legs under the rig's
    floor, which held the cloth flailing.

    :param skeleton: the character.
    :param up: the world's up, (3,) unit.
    :param floor: the floor's height along ``up``, m.
    :returns: (4,4) the root's pose in the world.
    """
    up = np.asarray(up, dtype=float)
    root = np.eye(4)
    root[:3, 3] = max(0.0, floor - _lowest_at_rest(skeleton, tuple(up))) * up
    return root


@functools.lru_cache(maxsize=16)
def _lowest_at_rest(skeleton, up):
    """Return body_proxy.lowest_reach of the zero pose, once per character (a crowd shares it)."""
    from .body_proxy import lowest_reach
    rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    return lowest_reach(skeleton, rest, np.array(up))


class InputParser:
    """Maps names to skeleton joints; holds the last value of joints a message leaves out.

    :param skeleton: the skeleton whose joints the messages move.
    :param world_joint: the prefix of the root's world pose variables (``world_joint/trans_x``).
    :param floor: (the world's up, the floor's height along it): until a message gives the
        world pose, the root stands the zero pose on that floor (:func:`standing_root`);
        None (no floor): the root at the origin.
    """

    def __init__(self, skeleton: 'Skeleton', world_joint: str = 'world_joint',
                 floor: 'tuple[npt.ArrayLike, float] | None' = None):
        self.skeleton = skeleton
        self.set_world_joint(world_joint)
        # The last sample: joints and a world pose that a message leaves out keep these.
        root = np.eye(4) if floor is None else standing_root(skeleton, *floor)
        self.last = JointSample(np.zeros(len(skeleton.joint_names)), root,
                                np.array([0.0, 0.0, 0.0, 1.0]))
        # Whether a message gave the world pose, and whether one parsed before it did not.
        self.world_given = self.guessed = False
        # Whether the last message gave part of the world pose (its travel then is lost).
        self.world_incomplete = False
        # The last message's names when none is a joint of the URDF (another robot's, or
        # prefixed): the body then stays as it is, which looks like a working node.
        self.unmatched = ''
        self.names = None           # the name list of the last message parsed
        # The joints a taken message has given: two sources on one topic (legs and arms)
        # each leave out the other's, which is no joint missing.
        self._given = np.zeros(len(skeleton.joint_names), dtype=bool)
        self._missing = self._missing_line()
        # Each name list's last taken stamp and the joints it gives: a source that stops
        # leaves its joints held while another goes on, which no input's warning shows.
        self._sources: dict = {}

    def set_world_joint(self, name: str) -> None:
        """Take the root's world pose from variables with another prefix; forget the plans.

        :param name: the new prefix.
        """
        self.world_joint = name
        self.world_names = {f'{name}/{v}': k for k, v in enumerate(WORLD_VARIABLES)}
        self._plans = {}

    def plan(self, names: tuple[str, ...]) -> tuple[NamePlan, list]:
        """Return where each name of a message goes, and the warnings its name list earns.

        Worked out once per distinct name list (a publisher sends the same list every time).
        The joints no taken message has given yet are said by :meth:`parse`: another source's
        list may give them.

        :param names: a message's joint name list.
        """
        plan = self._plans.get(names)
        if plan is not None:
            return plan
        index = self.skeleton.joint_index
        joint_from, joint_to, world_from, world_to, unknown = [], [], [], [], []
        mimics = self.skeleton.mimic_names
        for i, n in enumerate(names):
            if n in index:
                joint_from.append(i)
                joint_to.append(index[n])
            elif n in self.world_names:
                world_from.append(i)
                world_to.append(self.world_names[n])
            elif n not in mimics:
                unknown.append(n)
        warnings = []
        if len(set(names)) < len(names):
            # As robot_state_publisher (a map of positions): the last value of a name counts.
            seen, twice = set(), set()
            for n in names:
                (twice if n in seen else seen).add(n)
            warnings.append(('duplicate', f'joint(s) named more than once, the last value '
                             f'of each taken: {_names_cut(twice)}'))
        if unknown:
            warnings.append(('unknown', f'ignoring joint(s) not in the URDF: '
                             f'{_names_cut(unknown)}'))
        world = len(set(world_to))
        if 0 < world < len(WORLD_VARIABLES):
            warnings.append(('world', f'incomplete {self.world_joint}/* pose: '
                             'keeping the last world pose'))
        continuous = self.skeleton.continuous
        plan = (name_plan(joint_from, joint_to, world_from, world_to,
                          world == len(WORLD_VARIABLES), [continuous[k] for k in joint_to]),
                warnings)
        if len(self._plans) > 16:           # a publisher that changes its list every time
            self._plans.clear()
        self._plans[names] = plan
        return plan

    def _missing_line(self, given=None):
        """Return the line naming the joints no taken message has given (``given`` False)."""
        missing = np.flatnonzero(~(self._given if given is None else given))
        if not len(missing):
            return ''
        text = ', '.join(self.skeleton.joint_names[k] for k in missing[:5])
        return f'{len(missing)} joint(s) no message has given yet, held at zero: {text}'

    def parse(self, stamp_ns: int, names: Sequence[str], positions: npt.ArrayLike) -> Sample:
        """Return a message's skeleton sample; InputRejected if it cannot be used at all.

        :param stamp_ns: the message's stamp, ns.
        :param names: its joint names.
        :param positions: its positions, radians or metres by joint type, one per name.
        """
        names = tuple(names)
        positions = np.asarray(positions, dtype=float)
        if len(names) == 0 and len(positions) == 0:
            raise InputRejected('empty', 'empty JointState (no names, no positions): ignored')
        if len(names) != len(positions):
            raise InputRejected('length', f'JointState has {len(names)} names but '
                                f'{len(positions)} positions: message dropped')
        plan, warnings = self.plan(names)
        given, missing = self._given, self._missing
        if missing:         # the joints this message gives count once it is taken
            given = given.copy()
            given[plan.joint_to] = True
            missing = self._missing_line(given)
            if missing:
                warnings = warnings + [('missing', missing)]
        new = JointSample(np.empty_like(self.last.q), np.empty((4, 4)), np.empty(4))
        found = fill_sample(positions, plan, self.last, new)
        if found == NON_FINITE_POSITION:
            taken = set(plan.joint_from) | (set(plan.world_from) if plan.whole_world else set())
            bad = [n for k, (n, p) in enumerate(zip(names, positions))
                   if k in taken and not np.isfinite(p)]
            raise InputRejected('nonfinite', f'non-finite position for {", ".join(bad[:5])}: '
                                'message dropped')
        if found == ZERO_QUATERNION:
            raise InputRejected('world', f'{self.world_joint} rotation is a zero '
                                'quaternion: message dropped')
        self.last = new
        self.names = names
        self._given, self._missing = given, missing
        self._sources[names] = (stamp_ns, plan.joint_to, plan.whole_world)
        if len(self._sources) > MAX_SOURCES:       # a publisher that changes its list
            del self._sources[min(self._sources, key=lambda k: self._sources[k][0])]
        began = self.guessed and plan.whole_world
        self.world_incomplete = len(plan.world_to) > 0 and not plan.whole_world
        self.unmatched = _names_cut(set(names) - self.world_names.keys()) \
            if len(plan.joint_to) == 0 and len(self.skeleton.joint_names) and \
            any(code == 'unknown' for code, _ in warnings) else ''
        self.world_given = self.world_given or plan.whole_world
        self.guessed = not self.world_given
        return Sample(stamp_ns, new.q, new.root, new.quat, list(warnings), began)

    def held(self, latest_ns: int, silent_ns: int) -> str:
        """Say which joints, or world pose, only a source silent for over ``silent_ns`` gives.

        Their last values hold while another source goes on, as robot_state_publisher holds
        them. The last message's name list is never silent: steady inputs that repeat it are
        taken without this parser.

        :param latest_ns: the latest input's stamp, ns.
        :param silent_ns: how long a source may be silent, ns of the stamps.
        :returns: the line, or '' when nothing is held so.
        """
        # One flag more than the joints: the world pose (the world_joint/* variables).
        fresh = np.zeros(len(self._given) + 1, dtype=bool)
        stale = np.zeros(len(self._given) + 1, dtype=bool)
        last_ns = None
        for names, (stamp_ns, joints, world) in self._sources.items():
            now = names == self.names or latest_ns - stamp_ns <= silent_ns
            flags = fresh if now else stale
            flags[joints] = True
            flags[-1] |= world
            if not now:
                last_ns = stamp_ns if last_ns is None else max(last_ns, stamp_ns)
        held = np.flatnonzero(stale & ~fresh)
        if not len(held):
            return ''
        joints = held[held < len(self._given)]
        what = [f'the world pose ({self.world_joint}/*)'] if len(joints) < len(held) else []
        if len(joints):
            what.append(f'{len(joints)} joint(s) ('
                        + ', '.join(self.skeleton.joint_names[k] for k in joints[:5]) + ')')
        return (f'{" and ".join(what)} held at their last values, their source silent for '
                f'{(latest_ns - last_ns) * 1e-9:.1f} s of stamps while another goes on')


def _names_cut(names: 'Iterable[str]') -> str:
    """Return the first five of ``names``, sorted, each cut to 80 characters.

    A message's names are any length, a log line must not be.
    """
    return ', '.join(n if len(n) <= 80 else n[:80] + '...' for n in sorted(names)[:5])
