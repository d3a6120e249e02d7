# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The character's skeleton from its URDF, and vectorised forward kinematics.

The URDF is parsed with the ecosystem's parser (urdf_parser_py). Link transforms are computed
relative to the URDF root link (the character's local space, M14), one batched matrix product
per tree depth, so the cost grows with the depth of the tree, not its size.
"""

import io
import contextlib
import re
from xml.etree import ElementTree

import numpy as np
from urdf_parser_py import urdf

from .bundles import SkeletonModel, floats, ints
from .config import MAX_COORDINATE, ConfigError, MissingLink, read_text, shipped
from .physics.pose import ROTATION, TRANSLATION, forward_kinematics
from .transforms import make_transform, rpy_matrix

_MOVABLE = {'revolute': ROTATION, 'continuous': ROTATION, 'prismatic': TRANSLATION}


# Bounds on a URDF, checked before it is parsed: the largest robots and characters known have
# about 100 links and 100 kB, and a parse blocks the node for seconds per 10,000 links.
MAX_URDF_CHARS = 4 * 1024 * 1024
MAX_LINKS = 2048


class Skeleton:
    """Links, joints and forward kinematics of a URDF character.

    :param urdf_xml: the URDF's XML text.
    """

    def __init__(self, urdf_xml: str):
        if not isinstance(urdf_xml, str) or not urdf_xml.strip():
            raise ConfigError('URDF: empty robot description')
        if len(urdf_xml) > MAX_URDF_CHARS:
            raise ConfigError(f'URDF: {len(urdf_xml)} characters, over the {MAX_URDF_CHARS} a '
                              'character may have')
        links = urdf_xml.count('<link')
        if links > MAX_LINKS:
            raise ConfigError(f'URDF: {links} links, over the {MAX_LINKS} a character may have')
        text, ignored = _lenient(_readable(_without_declaration(urdf_xml)))
        try:
            # urdf_parser_py prints a line for each element it does not know: gathered into
            # one warning, as robot_state_publisher ignores them too.
            printed = io.StringIO()
            with contextlib.redirect_stderr(printed):
                robot = urdf.URDF.from_xml_string(text)
            root = robot.get_root()
        except Exception as e:  # noqa: BLE001 - the parser raises many kinds; all mean "bad URDF"
            # Its ParseError puts the reason on a line after the element's path: both, on one.
            lines = [t.strip() for t in str(e).strip().splitlines() if t.strip()]
            msg = ' '.join(lines) if lines else type(e).__name__
            raise ConfigError(f'URDF: malformed robot description ({msg})') from None
        ignored += [t.strip().replace('Unknown tag', 'unknown element')
                    for t in printed.getvalue().splitlines() if t.startswith('Unknown tag')]
        # What the parser left out, said once (issue 47 item 3): robot_state_publisher and RViz
        # load these URDFs, and so does the node.
        self.warnings = [] if not ignored else [
            f'URDF: ignored {len(ignored)} element(s) robot_state_publisher ignores too: '
            + '; '.join(ignored[:3]) + ('; ...' if len(ignored) > 3 else '')]
        # urdfdom (robot_state_publisher, RViz) refuses a name given twice; this parser kept
        # the last, and a character would move otherwise than they draw it.
        for kind, items in (('link', robot.links), ('joint', robot.joints)):
            twice = _first_twice(item.name for item in items)
            if twice is not None:
                raise ConfigError(f'URDF: malformed robot description ({kind} {twice!r} is '
                                  'defined twice, which robot_state_publisher refuses too)')
        self.name = robot.name
        self.root = root
        self.urdf_xml = urdf_xml          # its <collision> shapes can become colliders (rig)
        children = {}
        for j in robot.joints:
            children.setdefault(j.parent, []).append(j)
        # Breadth-first order: a link's parent always comes before it. The links placed so far
        # are a set: a list's search made a long chain quadratic.
        self.link_names = [root]
        placed = {root}
        parent, joints = [-1], [None]
        i = 0
        while i < len(self.link_names):
            for j in children.get(self.link_names[i], []):
                if j.child in placed:
                    raise ConfigError(f'URDF: link {j.child!r} has two parents')
                placed.add(j.child)
                self.link_names.append(j.child)
                parent.append(i)
                joints.append(j)
            i += 1
        self.link_index = {n: k for k, n in enumerate(self.link_names)}
        self.world_root = _is_world(robot, root, children)
        n = len(self.link_names)
        self.parent = np.array(parent)
        self.origin = np.tile(np.eye(4), (n, 1, 1))
        self.axis = np.zeros((n, 3))
        self.axis[:, 2] = 1.0
        self.kind = np.full(n, -1)        # -1 fixed, 0 rotation, 1 translation
        self.var = np.full(n, -1)         # index into joint_names
        self.mult = np.ones(n)
        self.offset = np.zeros(n)
        self.joint_names = []
        self.joint_of_link = {}
        mimics = []
        continuous = []
        for k, j in enumerate(joints):
            if j is None:
                continue
            self.joint_of_link[self.link_names[k]] = j.name
            if j.origin is not None:
                xyz = j.origin.xyz if j.origin.xyz is not None else [0, 0, 0]
                rpy = j.origin.rpy if j.origin.rpy is not None else [0, 0, 0]
                _check_numbers(j.name, 'origin xyz', xyz, MAX_COORDINATE)
                _check_numbers(j.name, 'origin rpy', rpy, 100.0)
                self.origin[k] = make_transform(rpy_matrix(rpy), xyz)
            if j.type in _MOVABLE:
                ax = np.array(j.axis if j.axis is not None else [1, 0, 0], dtype=float)
                if not np.isfinite(ax).all() or np.linalg.norm(ax) < 1e-9:
                    raise ConfigError(f'URDF: joint {j.name!r} has a zero or invalid axis')
                self.axis[k] = ax / np.linalg.norm(ax)
                self.kind[k] = _MOVABLE[j.type]
                if j.mimic is not None:
                    mimics.append((k, j))
                else:
                    self.var[k] = len(self.joint_names)
                    self.joint_names.append(j.name)
                    continuous.append(j.type == 'continuous')
        # Per joint value: a continuous joint's angle wraps (a driver may give it in +-pi).
        self.continuous = np.array(continuous, dtype=bool)
        index = {name: v for v, name in enumerate(self.joint_names)}
        mimicking = {j.name: j for _, j in mimics}
        for k, j in mimics:
            source, self.mult[k], self.offset[k] = _mimicked(j, mimicking)
            if source not in index:
                raise ConfigError(f'URDF: joint {j.name!r} mimics unknown joint {source!r}')
            self.var[k] = index[source]
            _check_numbers(j.name, 'mimic multiplier and offset',
                           [self.mult[k], self.offset[k]], 100.0)
            # A whole turn of the source is none of a follower at another ratio, or sliding:
            # its angle is taken as given.
            if self.kind[k] != ROTATION or self.mult[k] != round(self.mult[k]):
                self.continuous[index[source]] = False
        self.joint_index = index
        # A mimic joint's value is its source's: a JointState naming it is not told it is
        # unknown (robot_state_publisher ignores it too).
        self.mimic_names = frozenset(j.name for _, j in mimics)
        self.model = skeleton_model(self)

    def link(self, name: str, where: str = 'rig') -> int:
        """Return the index of a link; a ConfigError if the URDF has no such link.

        :param name: the link's name.
        :param where: what names it, the error's prefix.
        """
        if name not in self.link_index:
            raise MissingLink(f'{where}: link {name!r} is not in the URDF '
                              f'(links: {", ".join(self.link_names)})')
        return self.link_index[name]

    def forward(self, q: np.ndarray) -> np.ndarray:
        """Link transforms (L,4,4) in the root link's frame for joint values q (J,).

        :param q: the joint values (rad or m), in ``joint_names``' order.
        """
        world = np.empty((len(self.link_names), 4, 4))
        forward_kinematics(self.model, floats(q), world)
        return world


def _mimicked(joint, mimicking):
    """Return (the driven joint, multiplier, offset) a mimic joint follows, through mimics.

    A mimic of a mimic follows the first's source, its factors composed (as
    joint_state_publisher does); joints that mimic each other round a cycle follow nothing.

    :param joint: a mimic joint of urdf_parser_py.
    :param mimicking: every mimic joint, by name.
    """
    chain, mult, offset = [joint.name], 1.0, 0.0
    while True:
        m = joint.mimic
        factor = m.multiplier if m.multiplier is not None else 1.0
        offset += mult * (m.offset if m.offset is not None else 0.0)
        mult *= factor
        if m.joint not in mimicking:
            return m.joint, mult, offset
        if m.joint in chain:
            cycle = chain[chain.index(m.joint):] + [m.joint]
            shown_cycle = cycle if len(cycle) <= 6 else cycle[:5] + ['...', m.joint]
            who = (f'joint {cycle[0]!r} mimics itself' if len(cycle) == 2 else
                   f'{len(cycle) - 1} joints mimic each other in a cycle '
                   f'({" -> ".join(shown_cycle)})')
            raise ConfigError(f'URDF: {who}: none follows a joint that moves')
        chain.append(m.joint)
        joint = mimicking[m.joint]


def _is_world(robot, root, children):
    """Tell whether the root link is the world: massless, shapeless, fixed to every child.

    In a URDF that gives masses.
    Whatever its name (``world``, ``map``): robot descriptions as vendors publish them bolt
    the body to such a frame. It is the world, not a bone: no picture draws it, no body proxy
    wraps a capsule from it, and the node never publishes it as a child of the world frame
    (issue 47 item 3).
    """
    link = robot.link_map.get(root)
    joints = children.get(root, [])
    # Only where the URDF gives masses: a skeleton without any (the shipped character, a BVH
    # import) has massless links throughout, its root a bone like the others.
    masses = any(other.inertial is not None for other in robot.links)
    return bool(masses and link is not None and link.inertial is None and not link.visuals
                and not link.collisions and joints and all(j.type == 'fixed' for j in joints))


def _without_declaration(text):
    """Return the URDF text without its ``<?xml encoding?>`` line (lxml refuses it in a str)."""
    stripped = text.lstrip()
    if stripped.startswith('<?xml'):
        end = stripped.find('?>')
        if end > 0:
            return stripped[end + 2:]
    return text


def _lenient(text):
    """Return the URDF text without the empty elements urdfdom skips, and what was left out.

    An empty ``<texture/>`` in a material (no ``filename``) is refused by urdf_parser_py
    (``Required attribute not set in XML: filename``) but loaded by robot_state_publisher's
    urdfdom, which reads the filename only if there is one.
    """
    if '<texture' not in text:
        return text, []
    try:
        robot = ElementTree.fromstring(text)
    except ElementTree.ParseError:
        return text, []                   # urdf_parser_py says what is wrong with it
    ignored = []
    for material in robot.iter('material'):
        for texture in material.findall('texture'):
            if not texture.get('filename'):
                material.remove(texture)
                ignored.append(f'an empty <texture/> in material {material.get("name", "")!r}')
    if not ignored:
        return text, []
    return ElementTree.tostring(robot, encoding='unicode'), ignored


BALL_AXES = (('Z', '0 0 1'), ('X', '1 0 0'), ('Y', '0 1 0'))


def _readable(text):
    """Return the URDF text in the terms urdf_parser_py reads: pybullet's extensions turned.

    A ``spherical`` joint becomes three continuous joints about its frame's z, x and y (the
    usual BVH order, Zrotation Xrotation Yrotation), named and chained as BVH import names them
    (``<joint>_Zrotation`` ... through massless links ``<joint>_Zrotation_link`` ...); a
    ``<capsule>`` becomes a cylinder for the parser only (the colliders read the capsule); a
    trailing NUL byte is dropped. Other URDFs are passed on unchanged.
    """
    text = text.rstrip('\0 \r\n\t')
    if not re.search(r'type\s*=\s*["\']spherical|<capsule', text):
        return text
    try:
        robot = ElementTree.fromstring(text)
    except ElementTree.ParseError:
        return text                       # urdf_parser_py says what is wrong with it
    for geometry in robot.iter('geometry'):
        for g in geometry.findall('capsule'):
            g.tag = 'cylinder'
    for joint in list(robot.findall('joint')):
        if joint.get('type') != 'spherical':
            continue
        name, child = joint.get('name', ''), joint.find('child')
        index = list(robot).index(joint)
        robot.remove(joint)
        parent = joint.find('parent').get('link') if joint.find('parent') is not None else ''
        for i, (axis, xyz) in enumerate(BALL_AXES):
            last = i == len(BALL_AXES) - 1
            link = child.get('link') if last else f'{name}_{axis}rotation_link'
            if not last:
                ElementTree.SubElement(robot, 'link', name=link)
            part = ElementTree.Element('joint', name=f'{name}_{axis}rotation', type='continuous')
            ElementTree.SubElement(part, 'parent', link=parent)
            ElementTree.SubElement(part, 'child', link=link)
            if i == 0 and joint.find('origin') is not None:
                part.append(joint.find('origin'))
            ElementTree.SubElement(part, 'axis', xyz=xyz)
            robot.insert(index + i, part)
            parent = link
    return ElementTree.tostring(robot, encoding='unicode')


def _check_numbers(joint, what, values, limit):
    """Refuse a URDF's numbers unless finite and within ``limit``: no rig fits 1e308 m off."""
    try:
        v = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f'URDF: joint {joint!r} {what}: not numbers') from None
    if v.shape != (len(values),) or not np.isfinite(v).all() or (abs(v) > limit).any():
        raise ConfigError(f'URDF: joint {joint!r} {what} {v.tolist()}: each must be finite and '
                          f'within +-{limit}')


def _first_twice(names):
    """Return the first name met a second time, or None."""
    seen = set()
    for name in names:
        if name in seen:
            return name
        seen.add(name)
    return None


def shipped_character_urdf() -> str:
    """Return the shipped character's URDF text (config/character.urdf): the node's fallback."""
    with open(shipped('character.urdf'), encoding='utf-8') as f:
        return f.read()


def load_shipped_character() -> Skeleton:
    """Load the shipped character as a Skeleton, for the tools and the lab."""
    return Skeleton(shipped_character_urdf())


def skeleton_from(text: str, where: str) -> Skeleton:
    """Return the skeleton of a URDF's text read from a file.

    Every error names the file, an empty file too: it never means the shipped character.

    :param text: the URDF's XML text.
    :param where: the file, as errors name it (e.g. 'URDF path').
    """
    if not text.strip():
        raise ConfigError(f'{where}: empty file')
    try:
        return Skeleton(text)
    except ConfigError as e:
        message = str(e)
        if message.startswith('URDF: '):
            message = f'{where}: ' + message[len('URDF: '):]
        raise ConfigError(message) from None


def load_skeleton(path: str) -> Skeleton:
    """Load the skeleton of a URDF file; errors name the file.

    :param path: the URDF file.
    """
    return skeleton_from(read_text(path, 'URDF'), f'URDF {path}')


def skeleton_model(skeleton: Skeleton) -> SkeletonModel:
    """Return the kinematic arrays of a core.skeleton.Skeleton.

    :param skeleton: the character whose arrays the kernels take.
    """
    return SkeletonModel(floats(skeleton.origin), floats(skeleton.axis), ints(skeleton.kind),
                         ints(skeleton.var), floats(skeleton.mult), floats(skeleton.offset),
                         ints(skeleton.parent))
