# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""M10 colliders from a URDF's own ``<collision>`` shapes (the rig's ``colliders: from_urdf``).

A sphere becomes an ellipsoid with equal radii, a box the ellipsoid inscribed in it, a cylinder
a capsule that fits inside it, a ``<capsule>`` (the pybullet/SDF extension: ``length`` is the
segment between the two caps) a capsule. Meshes are skipped: no primitive to fit. Everything is
in the link's frame, as rig colliders are, so the link's own axes do not matter.
"""

from dataclasses import dataclass, field
from xml.etree import ElementTree

import numpy as np

from .config import MAX_COORDINATE, ConfigError
from .transforms import rpy_matrix


@dataclass
class UrdfShape:
    """One primitive collision shape of a link, in the link's frame."""

    link: str
    kind: str                   # 'sphere', 'box', 'cylinder', 'capsule'
    xyz: np.ndarray
    rotation: np.ndarray        # 3x3, the shape's axes in the link's frame
    rpy: np.ndarray             # the same as URDF roll-pitch-yaw (rad)
    size: np.ndarray = field(default_factory=lambda: np.zeros(3))  # box: full sizes
    radius: float = 0.0
    length: float = 0.0

    def as_collider(self, name: str) -> dict:
        """Return the rig collider entry (a dict as in a rig YAML) this shape becomes.

        :param name: the collider's name.
        """
        if self.kind in ('sphere', 'box'):
            radii = [self.radius] * 3 if self.kind == 'sphere' else list(self.size / 2)
            return {'name': name, 'type': 'ellipsoid', 'link': self.link,
                    'center': [float(v) for v in self.xyz],
                    'radii': [max(float(r), 1e-3) for r in radii],
                    'rpy_deg': [float(v) for v in np.degrees(self.rpy)]}
        axis_half = self.length / 2 - (0.0 if self.kind == 'capsule' else self.radius)
        half = max(axis_half, 0.0)
        axis = self.rotation[:, 2] * half
        return {'name': name, 'type': 'capsule', 'link': self.link,
                'a': [float(v) for v in self.xyz - axis], 'b': [float(v) for v in self.xyz + axis],
                'radius': max(self.radius, 1e-3)}

    def extent(self, direction: np.ndarray) -> float:
        """Half-extent of the shape along a unit direction given in the link's frame.

        :param direction: the unit direction, (3,) in the link's frame.
        """
        d = self.rotation.T @ direction
        if self.kind == 'sphere':
            return self.radius
        if self.kind == 'box':
            return float(np.abs(d) @ (self.size / 2))
        half = max(self.length / 2 - (0.0 if self.kind == 'capsule' else self.radius), 0.0)
        return abs(float(d[2])) * half + self.radius


def _floats(text, n, where):
    try:
        v = np.array([float(t) for t in (text or '').split()], dtype=float)
    except ValueError:
        raise ConfigError(f'{where}: not numbers ({text!r})') from None
    if v.shape != (n,) or not np.isfinite(v).all() or (abs(v) > MAX_COORDINATE).any():
        raise ConfigError(f'{where}: expected {n} finite numbers within +-{MAX_COORDINATE}, '
                          f'got {text!r}')
    return v


def urdf_shapes(urdf_xml: str) -> dict[str, list[UrdfShape]]:
    """Return every link's primitive collision shapes, by link name (links without: absent).

    :param urdf_xml: the URDF's XML text.
    """
    try:
        # Stripped at both ends: an XML declaration after a blank line is the parser's error.
        root = ElementTree.fromstring(urdf_xml.strip('\0 \r\n\t'))
    except ElementTree.ParseError as e:
        raise ConfigError(f'URDF: malformed robot description ({e})') from None
    out: dict[str, list[UrdfShape]] = {}
    for link in root.findall('link'):
        name = link.get('name', '')
        for k, col in enumerate(link.findall('collision')):
            where = f'URDF: link {name!r} collision {k}'
            origin = col.find('origin')
            xyz = _floats(origin.get('xyz', '0 0 0'), 3, f'{where} origin xyz') \
                if origin is not None else np.zeros(3)
            rpy = _floats(origin.get('rpy', '0 0 0'), 3, f'{where} origin rpy') \
                if origin is not None else np.zeros(3)
            geometry = col.find('geometry')
            shape = None
            for g in (list(geometry) if geometry is not None else []):
                if g.tag not in ('sphere', 'box', 'cylinder', 'capsule'):
                    continue
                shape = UrdfShape(name, g.tag, xyz, rpy_matrix(rpy), rpy)
                if g.tag == 'box':
                    shape.size = np.abs(_floats(g.get('size'), 3, f'{where} box size'))
                else:
                    shape.radius = abs(float(_floats(g.get('radius'), 1, f'{where} radius')[0]))
                if g.tag in ('cylinder', 'capsule'):
                    shape.length = abs(float(_floats(g.get('length'), 1, f'{where} length')[0]))
                break
            if shape is not None:
                out.setdefault(name, []).append(shape)
    return out


def collider_name(link: str, k: int, count: int) -> str:
    """Name of the k-th of ``count`` colliders made from one link's shapes.

    :param link: the link's name.
    :param k: the shape's index among the link's, from 0.
    :param count: how many colliders the link's shapes make.
    """
    return link if count == 1 else f'{link}_{k}'


def colliders_from_urdf(urdf_xml: str, links: list[str] | None = None) -> list[dict]:
    """Rig collider entries for the links' primitive shapes (every link's when ``links``=None).

    :param urdf_xml: the URDF's XML text.
    :param links: the links whose shapes become colliders; None: every link with shapes.
    """
    shapes = urdf_shapes(urdf_xml)
    names = list(shapes) if links is None else links
    out = []
    for link in names:
        mine = shapes.get(link, [])
        out.extend(s.as_collider(collider_name(link, k, len(mine))) for k, s in enumerate(mine))
    return out
