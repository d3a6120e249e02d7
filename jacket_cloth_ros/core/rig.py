# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The rig: how the jacket cloth, hood and colliders fit a URDF skeleton (config/*.yaml).

Everything is resolved against the skeleton's zero pose once, at load time: rest positions in
the character's local frame (the URDF root), and for each vertex the link and local offset that
carry its pinned target (M6) or its reference point (M11).

Axes: no link axis means up or forward. ``up`` (default +z) and ``forward`` (default +x) are
the body's in the URDF root's frame; the cloth shape and the M2 bones take their front, left
and up from them at the zero pose, unless an ``rpy_deg`` gives their axes in their link's frame
(docs/method.md). Gravity pulls along -``world_up``, a vector of the world the world joint moves
the root in: REP 103's +z unless the rig says otherwise, whatever the body's pose.
"""

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from .bone_layer import BoneLayer, layer_model
from .bundles import ClothModel, ColliderModel, Model, flags, floats, ints
from .config import ConfigError, Section, load_yaml, shipped, shown
from .transforms import apply_transform, invert_transform, rotation_between, rpy_matrix

if TYPE_CHECKING:           # for the annotations only
    from .skeleton import Skeleton

WORLD = -1          # the link index of colliders fixed in the world (a floor)
REGION_SCALES = ('damping_scale', 'wind_scale', 'world_share_scale', 'max_distance_scale')

#  Neighbour offsets (row, col) of the two constraint groups (M5).
STRETCH_OFFSETS = ((0, 1), (1, 0))
SHEAR_BEND_OFFSETS = ((1, 1), (1, -1), (0, 2), (2, 0))


@dataclass
class Collider:
    name: str
    link: int
    center: np.ndarray      # in the link's frame
    rotation: np.ndarray    # 3x3, ellipsoid axes in the link's frame
    radii: np.ndarray


@dataclass
class Capsule:
    name: str
    link: int
    a: np.ndarray           # segment ends in the link's frame
    b: np.ndarray
    radius: float


@dataclass
class Plane:
    name: str
    link: int               # WORLD for a plane fixed in the world (the floor)
    point: np.ndarray
    normal: np.ndarray      # unit; the cloth stays on this side


@dataclass
class Hood:
    link: int
    pivot: np.ndarray       # bone centre in the link's frame
    length: float
    rest_direction: np.ndarray  # unit, in the link's frame
    side: np.ndarray        # unit, in the link's frame: the body's left, the hood bone's y


def interleaved_order(a: npt.ArrayLike, b: npt.ArrayLike, window: int = 4) -> np.ndarray:
    """Return a top-down Gauss-Seidel order that keeps vertex-sharing constraints apart.

    No constraint shares a vertex with the ``window`` before it (the earliest such constraint
    comes next). Each projection then no longer waits for the one before it to store its vertex,
    so the CPU overlaps their square roots and divisions (docs/performance.md); the order stays
    top-down to within a few constraints.

    :param a: each constraint's first vertex, in top-down order.
    :param b: each constraint's second vertex.
    :param window: how many constraints before each share no vertex with it.
    :returns: the constraints' indices in the new order.
    """
    left = list(range(len(a)))
    order, recent = [], []
    while left:
        pick = 0
        for pos, j in enumerate(left):
            if all(a[j] not in pair and b[j] not in pair for pair in recent):
                pick = pos
                break
        j = left.pop(pick)
        order.append(j)
        recent = (recent + [(a[j], b[j])])[-window:]
    return np.array(order, dtype=np.int64)


def split_ellipsoid(center: npt.ArrayLike, rotation: np.ndarray, radii: npt.ArrayLike,
                    max_ratio: float = 2.0) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """M10: replace a badly stretched ellipsoid by overlapping, more uniform pieces.

    Pushing out in ellipsoid space bends the push direction more the more the ellipsoid is
    stretched, so the longest axis is cut until no piece's ratio exceeds ``max_ratio``.

    :param center: the ellipsoid's centre, (3,) in its link's frame.
    :param rotation: its axes as columns, 3x3.
    :param radii: its three radii, metres.
    :param max_ratio: the largest ratio of a piece's longest radius to its shortest.
    :returns: (center, rotation, radii) of each piece.
    """
    radii = np.asarray(radii, dtype=float)
    long_axis = int(np.argmax(radii))
    longest = radii[long_axis]
    shortest = np.delete(radii, long_axis).max()
    if longest <= shortest * max_ratio:
        return [(np.asarray(center, dtype=float), rotation, radii)]
    overlap = 1.25       # pieces overlap so that no seam between them lets cloth in
    pieces = int(np.ceil(overlap * longest / (shortest * max_ratio)))
    part = radii.copy()
    part[long_axis] = overlap * longest / pieces
    span = longest - part[long_axis]
    out = []
    for k in range(pieces):
        offset = -span + 2 * span * k / (pieces - 1)
        out.append((np.asarray(center, dtype=float) + rotation[:, long_axis] * offset,
                    rotation, part.copy()))
    return out


def body_axes(up: npt.ArrayLike, forward: npt.ArrayLike, where: str) -> np.ndarray:
    """Return columns forward, left, up (world) of a rig's up and forward vectors.

    One clear line if either is zero or they are parallel.

    :param up: the rig's up vector, world.
    :param forward: the rig's forward vector, world; made square to ``up``.
    :param where: the rig's place, for error messages.
    """
    up, forward = np.asarray(up, dtype=float), np.asarray(forward, dtype=float)
    for key, v in (('up', up), ('forward', forward)):
        if np.linalg.norm(v) < 1e-9:
            raise ConfigError(f'{where}.{key}: {v.tolist()} must not be zero')
    up = up / np.linalg.norm(up)
    forward = forward / np.linalg.norm(forward)
    across = forward - (forward @ up) * up
    if np.linalg.norm(across) < 0.1:            # within about 6 degrees of each other
        raise ConfigError(f'{where}: up {up.tolist()} and forward {forward.tolist()} are '
                          'parallel; forward must point across up')
    across /= np.linalg.norm(across)
    return np.column_stack([across, np.cross(up, across), up])


def _clean(rotation):
    """Return a rotation with exact zeros for -0.0, so a frame parallel to the world is exact."""
    return np.where(rotation == 0.0, 0.0, rotation)


# The body's up (root link to the hood's link) at the first input further than this (deg) from
# the world's up: the body lies down, which is said once and changes nothing (issue 47 item 1).
UP_TOLERANCE_DEG = 45.0
# A hood link's origin nearer the root than this share of the body's height says nothing of
# the body's up: the hood's pivot on that link does.
NEAR_ROOT_PER_HEIGHT = 0.1
REP103_UP = (0.0, 0.0, 1.0)     # the world's up when the rig does not say otherwise


def lying(body_up: np.ndarray, world_up: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Return a body's unit up and its angle from the world's up, where it lies down.

    :param body_up: (3,) the body's up in the world (pelvis or root to neck), any length.
    :param world_up: (3,) unit, the world's up.
    :returns: (the unit up, the angle in degrees), or None where the body stands within
        UP_TOLERANCE_DEG of the world's up or has no up.
    """
    length = np.linalg.norm(body_up)
    if not length > 1e-9:
        return None
    unit = body_up / length
    angle = float(np.degrees(np.arccos(np.clip(unit @ world_up, -1.0, 1.0))))
    return (unit, angle) if angle > UP_TOLERANCE_DEG else None


class Rig:
    """A validated rig fitted to a skeleton.

    :param data: the parsed rig YAML.
    :param skeleton: the skeleton it is fitted to.
    :param where: the rig's file, for error messages.
    """

    def __init__(self, data: dict, skeleton: 'Skeleton', where: str = 'rig'):
        top = Section(data, where)
        rest = skeleton.forward(np.zeros(len(skeleton.joint_names)))
        self.skeleton = skeleton
        self.world_axes = body_axes(top.vector('up', 3, [0.0, 0.0, 1.0]),
                                    top.vector('forward', 3, [1.0, 0.0, 0.0]), where)
        self.up = self.world_axes[:, 2].copy()
        # The world's up, where the motion lives (gravity, the floor): the world's own (REP
        # 103), never the body's: a Y-up URDF stands in a Z-up world through its world joint,
        # and a body on the floor lies in it (issue 47 item 1).
        self.world_up = np.array(REP103_UP)
        if top.has('world_up'):
            world_up = np.array(top.vector('world_up', 3))
            if np.linalg.norm(world_up) < 1e-9:
                raise ConfigError(f'{where}.world_up: {world_up.tolist()} must not be zero')
            self.world_up = world_up / np.linalg.norm(world_up)
        self._rest = rest
        # The skeleton's extent along up at rest, link origins: what thresholds scale with.
        self.height_m = float(np.ptp(rest[:, :3, 3] @ self.up))
        cloth = top.section('cloth')
        self.cols = cloth.integer('cols', lo=3, hi=64)
        self.rows = cloth.integer('rows', lo=3, hi=64)
        shape = cloth.section('shape')
        shape_link = skeleton.link(shape.text('link'), f'{where}.cloth.shape.link')
        center = np.array(shape.vector('center'))
        radii = np.array(shape.vector('radii', 2, lo=0.01, hi=5.0))
        flare = shape.number('flare', 0.0, lo=-0.05, hi=0.1)
        opening = np.radians(shape.number('opening_deg', 40.0, lo=0.0, hi=180.0))
        spacing = shape.number('row_spacing', lo=0.005, hi=1.0)
        axes = self.axes_at(shape_link, shape)
        shape.reject_unknown()
        # Column c runs from the left front edge round the back to the right front edge, rows
        # hang down; built along the shape's front, left and up axes, then placed at center.
        theta = np.linspace(opening / 2, 2 * np.pi - opening / 2, self.cols)
        pts = np.empty((self.rows, self.cols, 3))
        for r in range(self.rows):
            rx, ry = radii + flare * r
            pts[r, :, 0] = rx * np.cos(theta)
            pts[r, :, 1] = ry * np.sin(theta)
            pts[r, :, 2] = -spacing * r
        local = center + pts.reshape(-1, 3) @ axes.T
        self.rest = apply_transform(rest[shape_link], local)   # (N,3) in the root frame

        self.pin_link = skeleton.link(cloth.text('pin_link'), f'{where}.cloth.pin_link')
        self.pin_local = apply_transform(invert_transform(rest[self.pin_link]),
                                         self.rest[:self.cols])

        bones = cloth.texts('reference_bones')
        if not bones:
            raise ConfigError(f'{where}.cloth.reference_bones: needs at least one link')
        bone_ids = [skeleton.link(b, f'{where}.cloth.reference_bones') for b in bones]
        self.reference_link = self._nearest_bones(bone_ids, rest)
        to_bone = np.linalg.inv(rest[self.reference_link])
        self.reference_local = np.einsum('nij,nj->ni', to_bone[:, :3, :3], self.rest)
        self.reference_local += to_bone[:, :3, 3]
        md = cloth.section('max_distance')
        top_d, hem_d = md.number('top', lo=0.0, hi=5.0), md.number('hem', lo=0.0, hi=5.0)
        md.reject_unknown()
        row = np.repeat(np.arange(self.rows), self.cols) / (self.rows - 1)
        self.max_distance = top_d + (hem_d - top_d) * row
        self.bone_column_step = cloth.integer('bone_column_step', 2, lo=1, hi=self.cols)
        self._load_regions(cloth, f'{where}.cloth')
        cloth.reject_unknown()

        hood = top.section('hood')
        direction = np.array(hood.vector('rest_direction'))
        if np.linalg.norm(direction) < 1e-9:
            raise ConfigError(f'{where}.hood.rest_direction: must not be zero')
        hood_link = skeleton.link(hood.text('link'), f'{where}.hood.link')
        self.hood = Hood(
            link=hood_link,
            pivot=np.array(hood.vector('pivot')),
            length=hood.number('length', lo=0.01, hi=2.0),
            rest_direction=direction / np.linalg.norm(direction),
            side=self.axes_at(hood_link)[:, 1].copy())
        hood.reject_unknown()

        self._load_colliders(top, skeleton, where)
        layer = top.section('jacket_bones') if top.has('jacket_bones') else None
        self.layer = BoneLayer(layer, skeleton, rest, f'{where}.jacket_bones',
                               self.axes_at) if layer else None
        self._skin_top_row(rest)
        top.reject_unknown()
        self._build_topology()
        # On /tf beside the URDF's links (robot_state_publisher's): a bone named as a link
        # would give that frame two parents, and tf2 would take either.
        clash = [n for n in self.bone_names() if n in skeleton.link_index]
        if clash:
            layer = set(self.layer.names if self.layer else ())
            raise ConfigError(f'{where}: the jacket\'s bone(s) {", ".join(map(repr, clash))} '
                              'would go on /tf under the name of a link of the URDF '
                              f'{skeleton.name!r}: one frame, two parents; rename the link'
                              + (' (or the bone in jacket_bones)' if layer >= set(clash)
                                 else ''))

    def axes_at(self, link: int, section: Section | None = None) -> np.ndarray:
        """Return a part's front, left and up axes (columns) in its link's frame.

        :param link: the part's link index.
        :param section: the part's rig section; from its ``rpy_deg`` if it has one, else the rig's
            forward and up seen from the link at the zero pose.
        """
        if section is not None and section.has('rpy_deg'):
            return rpy_matrix(np.radians(section.vector('rpy_deg', 3, lo=-360.0, hi=360.0)))
        return _clean(self._rest[link][:3, :3].T @ self.world_axes)

    def floor(self) -> tuple[np.ndarray, float] | None:
        """Return the world's up and the floor's height along it, or None without a floor.

        The floor: the highest plane fixed in the world that faces up (within 60 degrees).
        """
        heights = [float(p.point @ self.world_up) for p in self.planes
                   if p.link == WORLD and p.normal @ self.world_up > 0.5]
        return (self.world_up, max(heights)) if heights else None

    def body_tilt(self, links: np.ndarray, root_rotation: np.ndarray
                  ) -> tuple[np.ndarray, float] | None:
        """Return the body's up in the world and its angle from the world's up, if far from it.

        The body's up is the root link to the hood's link in the world, or to the hood's
        pivot where that link's origin is near the root (Unitree G1 puts its head link's at
        its pelvis). Further than UP_TOLERANCE_DEG from ``world_up`` the body lies down (a
        capture that starts on the floor, a Y-up URDF whose world joint does not stand it
        up); the world's up stays.

        :param links: the link transforms (L, 4, 4) in the root's frame, at a pose.
        :param root_rotation: the root's rotation in the world, (3, 3).
        :returns: (the body's up, (3,) unit, the angle from ``world_up`` in degrees), or None
            where the body stands within UP_TOLERANCE_DEG of it.
        """
        link = links[self.hood.link]
        up = link[:3, 3] - links[0][:3, 3]
        if np.linalg.norm(up) < NEAR_ROOT_PER_HEIGHT * self.height_m:
            up = link[:3, :3] @ self.hood.pivot + up
        return lying(np.asarray(root_rotation, float) @ up, self.world_up)

    def view_axes(self, world_up: npt.ArrayLike | None = None,
                  root_rotation: npt.ArrayLike | None = None) -> np.ndarray:
        """Return the world's forward, left and up as columns: the views' axes.

        The body's axes (``up``, ``forward``: the URDF root frame's) turned so that up is the
        world's, where a world joint turns the root (a Y-up URDF driven in a Z-up world).
        Given the root's rotation in the world, they are turned about up by the quarter turns
        that bring forward nearest to where the body faces there: a character turned in the
        world (retargeted, a capture facing the other way) is seen from its front, not its
        back, and the views stay on the world's axes. A body whose own up is tilted more than
        half a right angle from the world's (lying, crawling) is turned to where its head lies
        instead: the side view shows it along its length, not end-on.

        :param world_up: the world's up, (3,) unit; None: the rig's ``world_up``.
        :param root_rotation: the root's rotation in the world (3, 3) at the moment the views
            face; None: the body's forward as the URDF has it.
        :returns: (3, 3), forward, left and up as columns.
        """
        up = self.world_up if world_up is None else np.asarray(world_up, float)
        axes = rotation_between(self.up, up) @ self.world_axes
        if root_rotation is None:
            return axes
        turned = np.asarray(root_rotation, float) @ self.world_axes
        front, head = (v - (v @ up) * up for v in (turned[:, 0], turned[:, 2]))
        # Tilted more than half a right angle from upright: lying on its front, back or side,
        # or crawling, where the body's length is what the side view should show.
        if np.linalg.norm(head) > np.sqrt(0.5):
            front = head
        quarter = int(np.argmax([front @ axes[:, 0], front @ axes[:, 1], -front @ axes[:, 0],
                                 -front @ axes[:, 1]]))
        for _ in range(quarter):            # a quarter turn about up: forward to left
            axes = np.column_stack([axes[:, 1], -axes[:, 0], axes[:, 2]])
        return axes

    def _load_regions(self, cloth, where):
        """Per-region multipliers of the fabric's damping, wind, world share and M11 bound.

        A region is a block of rows and columns (inclusive ranges); later regions multiply
        onto earlier ones. Edges (M13) keep their own values, which the regions then scale.
        """
        self.region_scale = {k: np.ones(self.rows * self.cols) for k in REGION_SCALES}
        grid_r, grid_c = np.divmod(np.arange(self.rows * self.cols), self.cols)
        for i, r in enumerate(cloth.sections('regions')):
            key = f'{where}.regions[{i}]'
            r.text('name', f'region_{i}')
            r0, r1 = r.vector('rows', 2)
            c0, c1 = r.vector('cols', 2)
            if not (0 <= r0 <= r1 < self.rows and 0 <= c0 <= c1 < self.cols):
                raise ConfigError(f'{key}: rows/cols must be ranges inside the '
                                  f'{self.rows}x{self.cols} grid')
            inside = (grid_r >= r0) & (grid_r <= r1) & (grid_c >= c0) & (grid_c <= c1)
            for k in REGION_SCALES:
                self.region_scale[k][inside] *= r.number(k, 1.0, lo=0.0, hi=10.0)
            r.reject_unknown()

    def _load_colliders(self, top, skeleton, where):
        """M10 ellipsoids (split when stretched), capsules and planes, each riding on a link."""
        self.colliders, self.capsules, self.planes = [], [], []
        for key, c in _collider_entries(top, skeleton, where):
            kind = c.text('type', 'ellipsoid', choices=('ellipsoid', 'capsule', 'plane'))
            name = c.text('name', f'collider_{key.rsplit("[", 1)[-1].rstrip("]")}')
            link_name = c.text('link')
            if kind == 'plane' and link_name == 'world':
                link = WORLD
            else:
                link = skeleton.link(link_name, f'{key}.link')
            if kind == 'ellipsoid':
                radii = np.array(c.vector('radii', lo=1e-3, hi=5.0))
                rotation = rpy_matrix(np.radians(c.vector('rpy_deg', 3, [0, 0, 0])))
                for k, (ctr, rot, rad) in enumerate(split_ellipsoid(c.vector('center'),
                                                                    rotation, radii)):
                    self.colliders.append(Collider(f'{name}_{k}', link, ctr, rot, rad))
            elif kind == 'capsule':
                self.capsules.append(Capsule(name, link, np.array(c.vector('a')),
                                             np.array(c.vector('b')),
                                             c.number('radius', lo=1e-3, hi=5.0)))
            else:
                normal = np.array(c.vector('normal'))
                if np.linalg.norm(normal) < 1e-9:
                    raise ConfigError(f'{key}.normal: must not be zero')
                self.planes.append(Plane(name, link, np.array(c.vector('point')),
                                         normal / np.linalg.norm(normal)))
            c.reject_unknown()
        # The same colliders as arrays, for the per-step transform.
        self.collider_links = np.array([c.link for c in self.colliders], dtype=int)
        self.collider_centers = np.array([c.center for c in self.colliders]).reshape(-1, 3)
        self.collider_rotations = np.array([c.rotation for c in self.colliders]).reshape(-1, 3, 3)
        self.collider_radii = np.array([c.radii for c in self.colliders]).reshape(-1, 3)
        self.capsule_links = np.array([c.link for c in self.capsules], dtype=int)
        self.capsule_ends = np.array([[c.a, c.b] for c in self.capsules]).reshape(-1, 2, 3)
        self.capsule_radii = np.array([c.radius for c in self.capsules], dtype=float)
        self.plane_links = np.array([p.link for p in self.planes], dtype=np.int64)
        self.plane_points = np.array([p.point for p in self.planes], dtype=float).reshape(-1, 3)
        self.plane_normals = np.array([p.normal for p in self.planes], dtype=float).reshape(-1, 3)

    def _skin_top_row(self, rest):
        """M6 + M2: skin the pinned top row to its link and, near the shoulders, the pads' bones.

        Those are the bones below the shoulder pads; their weight falls off linearly to zero at
        ``skin_radius``.
        """
        top = self.rest[:self.cols]
        self.pin_weight = np.zeros(self.cols)
        self.pin_below = np.zeros(self.cols, dtype=int)
        self.pin_below_local = np.zeros((self.cols, 3))
        if self.layer is None or not self.layer.pads or self.layer.skin_radius <= 0:
            return
        below = self.layer.solve(rest, full=False).below
        dist = np.empty((self.cols, len(below)))
        for k, (frame, pad) in enumerate(zip(below, self.layer.pads)):
            a = frame[:3, 3]
            ab = frame[:3, 0] * pad.below_length
            t = np.clip((top - a) @ ab / (ab @ ab), 0.0, 1.0)
            dist[:, k] = np.linalg.norm(top - (a + t[:, None] * ab), axis=1)
        self.pin_below = np.argmin(dist, axis=1)
        self.pin_weight = np.clip(1.0 - dist.min(axis=1) / self.layer.skin_radius, 0.0, 1.0)
        for i in range(self.cols):
            frame = below[self.pin_below[i]]
            self.pin_below_local[i] = frame[:3, :3].T @ (top[i] - frame[:3, 3])

    def _nearest_bones(self, bone_ids, rest):
        """M11: each vertex's reference point rides on the nearest bone segment."""
        sk = self.skeleton
        segments = []
        for b in bone_ids:
            start = rest[b][:3, 3]
            kids = np.nonzero(sk.parent == b)[0]
            end = rest[kids[0]][:3, 3] if len(kids) else start
            segments.append((start, end))
        dist = np.empty((len(self.rest), len(bone_ids)))
        for k, (a, b) in enumerate(segments):
            ab = b - a
            t = np.clip(((self.rest - a) @ ab) / max(ab @ ab, 1e-12), 0.0, 1.0)
            dist[:, k] = np.linalg.norm(self.rest - (a + t[:, None] * ab), axis=1)
        return np.array(bone_ids)[np.argmin(dist, axis=1)]

    def _build_topology(self):
        """Constraints in Gauss-Seidel order (top-down, interleaved), M5 and M12 lists."""
        R, C = self.rows, self.cols
        a, b, group = [], [], []
        for r in range(R):
            for c in range(C):
                for g, offsets in enumerate((STRETCH_OFFSETS, SHEAR_BEND_OFFSETS)):
                    for dr, dc in offsets:
                        r2, c2 = r + dr, c + dc
                        if r2 < R and 0 <= c2 < C:
                            a.append(r * C + c)
                            b.append(r2 * C + c2)
                            group.append(g)
        order = interleaved_order(a, b)
        self.con_a = np.array(a, dtype=np.int64)[order]
        self.con_b = np.array(b, dtype=np.int64)[order]
        self.con_group = np.array(group, dtype=np.int64)[order]   # 0 stretch, 1 shear/bend
        self.con_rest = np.linalg.norm(self.rest[self.con_a] - self.rest[self.con_b], axis=1)
        # M12: the vertical stretch constraints, top-down; only the lower end moves.
        self.vert_b = np.arange(C, R * C, dtype=np.int64)
        self.vert_a = self.vert_b - C
        self.vert_rest = np.linalg.norm(self.rest[self.vert_a] - self.rest[self.vert_b], axis=1)
        self.horiz = (self.con_group == 0) & (self.con_b == self.con_a + 1)
        # M13: edge vertices have fewer than four stretch constraints (an interior vertex has
        # four neighbours: left, right, up, down): the hem, the front opening, the top row.
        count = np.zeros(R * C, dtype=int)
        stretch = self.con_group == 0
        np.add.at(count, self.con_a[stretch], 1)
        np.add.at(count, self.con_b[stretch], 1)
        self.edge = count < 4
        self.free = np.ones(R * C, dtype=bool)
        self.free[:C] = False                              # M6: the pinned top row
        # Long-range attachments: each vertex is tied to the nearest pinned vertex at rest.
        to_top = np.linalg.norm(self.rest[:, None] - self.rest[None, :C], axis=2)
        self.tether_anchor = np.argmin(to_top, axis=1).astype(np.int64)
        self.tether_length = to_top.min(axis=1)

    @property
    def n(self) -> int:
        return self.rows * self.cols

    def bone_vertices(self) -> list[tuple[int, int]]:
        """M9: vertices that carry bones (every row but the last, every n-th column)."""
        cols = list(range(0, self.cols, self.bone_column_step))
        return [(r, c) for r in range(self.rows - 1) for c in cols]

    def bone_names(self) -> list[str]:
        """Every bone's frame as published: M9 cloth bones, the M8 hood, M1/M2 layer bones."""
        return ([f'jacket_r{r:02d}_c{c:02d}' for r, c in self.bone_vertices()] + ['hood']
                + (self.layer.names if self.layer else []))


def _collider_entries(top, skeleton, where):
    """Return the rig's collider entries as (key, Section): a list as written, or from the URDF.

    ``colliders: from_urdf`` takes every link's primitive ``<collision>`` shape;
    ``colliders: {from_urdf: [links] or all, drop: [names], add: [entries]}`` takes some links',
    drops generated colliders by name and adds entries (one named as a generated collider
    replaces it).
    """
    from .urdf_colliders import colliders_from_urdf
    value = top._data.get('colliders', [])
    key = f'{where}.colliders'
    if isinstance(value, list) or not top.has('colliders'):
        return [(f'{key}[{i}]', c) for i, c in enumerate(top.sections('colliders'))]
    top._used.add('colliders')
    if value == 'from_urdf':
        value = {'from_urdf': 'all'}
    if not isinstance(value, dict):
        raise ConfigError(f'{key}: expected a list of colliders, from_urdf, or a mapping with '
                          f'from_urdf, drop and add, got {shown(value)}')
    spec = Section(value, key)
    links = spec._data.get('from_urdf', 'all')
    if isinstance(links, str):
        spec.text('from_urdf', choices=('all',))
    else:
        links = spec.texts('from_urdf')
    if isinstance(links, list):
        for link in links:
            skeleton.link(link, f'{key}.from_urdf')
    generated = colliders_from_urdf(skeleton.urdf_xml, None if links == 'all' else links)
    if not generated:
        raise ConfigError(f'{key}.from_urdf: the URDF has no sphere, box, cylinder or capsule '
                          '<collision> shape on those links (meshes are not used); list '
                          'colliders instead')
    names = [g['name'] for g in generated]
    for name in spec.texts('drop', []):
        if name not in names:
            raise ConfigError(f'{key}.drop: {name!r} is not a collider made from the URDF '
                              f'({", ".join(names)})')
        generated = [g for g in generated if g['name'] != name]
        names.remove(name)
    added = spec.sections('add')
    spec.reject_unknown()
    replaced = {a._data.get('name') for a in added}
    entries = [(f'{key}.from_urdf[{g["name"]}]', Section(g, f'{key}.from_urdf[{g["name"]}]'))
               for g in generated if g['name'] not in replaced]
    return entries + [(f'{key}.add[{i}]', a) for i, a in enumerate(added)]


def load_rig(skeleton: 'Skeleton', path: str | None = None) -> Rig:
    """Return the rig of a YAML file, fitted to ``skeleton``.

    :param skeleton: the skeleton the rig is fitted to.
    :param path: the rig file; None: the shipped ``jacket_rig.yaml``.
    """
    path = path or shipped('jacket_rig.yaml')
    return Rig(load_yaml(path), skeleton, where=path)


def cloth_model(rig: Rig) -> ClothModel:
    """Return a core.rig.Rig's cloth, pins, references and hood.

    :param rig: the rig.
    """
    pinned_a, pinned_b = ~rig.free[rig.con_a], ~rig.free[rig.con_b]
    held, top_row = rig.horiz & ~(pinned_a & pinned_b), rig.horiz & pinned_a & pinned_b
    # Row by row, as the hard pass walks them (physics.cloth.hard_pass_with_strain_limit).
    held = np.flatnonzero(held)[np.argsort(rig.con_a[held] // rig.cols, kind='stable')]
    return ClothModel(
        int(rig.pin_link), floats(rig.pin_local), ints(rig.reference_link),
        floats(rig.reference_local), ints(rig.pin_below), floats(rig.pin_below_local),
        floats(rig.pin_weight), flags(rig.free), ints(rig.con_a), ints(rig.con_b),
        floats(rig.con_rest), ints(rig.vert_a), ints(rig.vert_b), floats(rig.vert_rest),
        ints(rig.con_a[held]), ints(rig.con_b[held]), floats(rig.con_rest[held]),
        ints(rig.con_a[top_row]), floats(rig.con_rest[top_row]), ints(rig.tether_anchor),
        floats(rig.tether_length), int(rig.hood.link),
        floats(rig.hood.pivot), float(rig.hood.length), floats(rig.hood.side),
        floats(rig.world_up))


def collider_model(rig: Rig) -> ColliderModel:
    """Return a core.rig.Rig's colliders in their links' frames.

    :param rig: the rig.
    """
    return ColliderModel(
        ints(rig.collider_links), floats(rig.collider_centers), floats(rig.collider_rotations),
        floats(rig.collider_radii), ints(rig.capsule_links), floats(rig.capsule_ends),
        floats(rig.capsule_radii), ints(rig.plane_links), floats(rig.plane_points),
        floats(rig.plane_normals))


def model_of(skeleton: 'Skeleton', rig: Rig) -> Model:
    """Return the fixed bundle of a skeleton and the rig fitted to it.

    :param skeleton: the skeleton.
    :param rig: the rig fitted to it.
    """
    return Model(skeleton.model, rig.layer.model if rig.layer else layer_model(), cloth_model(rig),
                 collider_model(rig))
