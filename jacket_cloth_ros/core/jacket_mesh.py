# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The jacket and hood a person sees: a skinned mesh generated from the rig (M1, M2, M3, M8).

The seed's jacket is "a normal skinned mesh ... the skeleton that drives it is a separate layer
above the normal skeleton". The simulation publishes that layer's bones; this module makes the
mesh they drive, for any rig, with no hand-made asset:

- **lower jacket (M3, M9):** the cloth grid's rest shape, subdivided round the body, skinned
  bilinearly to the M9 grid bones around each vertex (the hem row rides on the bones above it);
- **shoulders and yoke (M2):** rings from the cloth's top row up to the shoulder line, out to the
  pads' tips, and in to the neck, skinned to the upper jacket's link and, at the sides, to the
  shoulder-pad bones;
- **collar:** two rings round the neck, skinned to the upper link and the hood's link;
- **sleeves (M1):** a tube round each arm chain, skinned along each segment from its main bone to
  its twist bone, blended with the next segment's main bone at the elbow (the bent bone) and
  with the shoulder pad at the top;
- **hood (M8):** a shell hanging behind the neck along the hood bone, its rim blended with the
  hood's link.

Open surfaces (lower jacket, yoke, collar, hood) carry back faces, the lining, so they read from
both sides. Skinning weights are made by construction (each vertex names the bones it lies
between); each row of weights sums to one. Joints are the skeleton's links, then the published
bones in their order (simulation.BoneSet): the M9 grid bones, the M8 hood bone, the M1/M2 layer.
"""

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .bundles import floats, ints
from .physics import pose, skinning
from .rig import cloth_model

if TYPE_CHECKING:           # for the annotations only
    from .rig import Rig
    from .skeleton import Skeleton

INFLUENCES = 4               # joints per vertex, as glTF's JOINTS_0
SUBDIVIDE = 2                # mesh columns per cloth column, round the body
RING_SIDES = 10              # vertices round a sleeve
HOOD_ROWS, HOOD_SIDES = 6, 9

# Parts, for colours and tests.
LOWER, YOKE, COLLAR, SLEEVE, HOOD, BODY = range(6)
PART_NAMES = ('lower jacket', 'yoke', 'collar', 'sleeve', 'hood', 'body')
TWEED = (0.46, 0.36, 0.26, 1.0)
LINING = (0.30, 0.12, 0.12, 1.0)
SKIN = (0.78, 0.74, 0.70, 1.0)
PART_COLORS = (TWEED, TWEED, (0.40, 0.31, 0.22, 1.0), TWEED, (0.50, 0.39, 0.28, 1.0), SKIN)


@dataclass(frozen=True)
class SkinnedMesh:
    """A mesh skinned to joints (links, then bones), at rest in the simulation frame.

    ``triangles`` wind counter-clockwise seen from outside; back faces are listed after the
    front faces they line, wound the other way (``back`` True).
    """

    rest: np.ndarray            # (V,3)
    triangles: np.ndarray       # (T,3) int64
    joints: np.ndarray          # (V,INFLUENCES) int64
    weights: np.ndarray         # (V,INFLUENCES), rows sum to one
    part: np.ndarray            # (T,) int64: LOWER ... HOOD
    back: np.ndarray            # (T,) bool
    joint_names: tuple          # the joints' names: link names, then bone names
    inverse_rest: np.ndarray    # (J,3,4) each joint's inverse at rest

    @property
    def colors(self) -> np.ndarray:
        """Each triangle's base colour (T,4): the part's, the lining's on back faces."""
        c = np.array(PART_COLORS)[self.part]
        c[self.back] = LINING
        return c


class MeshBuilder:
    """Vertices, triangles and weights, part by part (the jacket's; body_mesh's too)."""

    def __init__(self):
        self.points, self.influences, self.tris, self.parts, self.backs = [], [], [], [], []

    def vertex(self, p: np.ndarray, influences: dict) -> int:
        """Add a vertex; return its index.

        :param p: its rest position, (3,).
        :param influences: {joint: weight}; normalised, the largest INFLUENCES kept.
        """
        self.points.append(np.asarray(p, float))
        self.influences.append(influences)
        return len(self.points) - 1

    def quad_strip(self, a: list, b: list, part: int, lining: bool, closed: bool = False) -> None:
        """Add the triangles between two rows of vertex indices.

        :param a: one row's vertices.
        :param b: the next row's, as many.
        :param part: the part they belong to.
        :param lining: add back faces too.
        :param closed: the rows are rings (the last vertex joins the first).
        """
        n = len(a)
        for i in range(n if closed else n - 1):
            j = (i + 1) % n
            for tri in ((a[i], b[i], b[j]), (a[i], b[j], a[j])):
                self.triangle(tri, part, lining)

    def triangle(self, tri: tuple, part: int, lining: bool) -> None:
        """Add a triangle, and its back face with ``lining``.

        :param tri: its three vertex indices.
        :param part: the part it belongs to.
        :param lining: add its back face too.
        """
        self.tris.append(tri)
        self.parts.append(part)
        self.backs.append(False)
        if lining:
            self.tris.append((tri[0], tri[2], tri[1]))
            self.parts.append(part)
            self.backs.append(True)

    def done(self, joint_names: list, inverse_rest: np.ndarray) -> 'SkinnedMesh':
        """Return the mesh built.

        :param joint_names: the joints' names.
        :param inverse_rest: (J,3,4) each joint's inverse at rest.
        """
        joints = np.zeros((len(self.points), INFLUENCES), dtype=np.int64)
        weights = np.zeros((len(self.points), INFLUENCES))
        for v, inf in enumerate(self.influences):
            kept = sorted(((w, j) for j, w in inf.items() if w > 1e-6), reverse=True)
            kept = kept[:INFLUENCES]
            total = sum(w for w, _ in kept)
            for k, (w, j) in enumerate(kept):
                joints[v, k], weights[v, k] = j, w / total
        return SkinnedMesh(floats(np.array(self.points)), np.array(self.tris, dtype=np.int64),
                           joints, weights, np.array(self.parts, dtype=np.int64),
                           np.array(self.backs, dtype=bool), tuple(joint_names), inverse_rest)


def rest_joints(skeleton: 'Skeleton', rig: 'Rig', bone_parents: np.ndarray,
                grid: np.ndarray) -> np.ndarray:
    """Return every joint at rest (links, then bones), (J,3,4), in the simulation frame.

    :param skeleton: the character.
    :param rig: its rig.
    :param bone_parents: (B,) each bone's parent link, in the published order.
    :param grid: (G,2) the M9 grid bones' (row, column).
    """
    links = skeleton.forward(np.zeros(len(skeleton.joint_names)))
    cloth = cloth_model(rig)
    t = links[rig.hood.link]
    hood_p = t[:3, :3] @ (rig.hood.pivot + rig.hood.rest_direction * rig.hood.length) + t[:3, 3]
    layer = rig.layer.solve(links) if rig.layer else None
    poses = np.empty((len(bone_parents), 7))
    empty = np.zeros((0, 3))
    pose.bone_poses(floats(rig.rest), floats(hood_p), floats(links), cloth, ints(grid),
                    ints(layer.parents if layer else []),
                    floats(layer.rotations if layer else np.zeros((0, 3, 3))),
                    floats(layer.positions if layer else empty), poses)
    return posed_joints(links, ints(bone_parents), poses)


def inverse(joints: np.ndarray) -> np.ndarray:
    """Return the inverses of rigid joints (J,3,4).

    :param joints: (J,3,4) rotation and translation.
    """
    rt = np.transpose(joints[:, :, :3], (0, 2, 1))
    return np.concatenate([rt, -np.einsum('jik,jk->ji', rt, joints[:, :, 3])[:, :, None]], axis=2)


def jacket_mesh(skeleton: 'Skeleton', rig: 'Rig', bone_names: list, bone_parents: list,
                grid: np.ndarray) -> SkinnedMesh:
    """Build the jacket and hood mesh of a rig, skinned to its links and published bones.

    :param skeleton: the character.
    :param rig: its rig.
    :param bone_names: the published bones' names (simulation.BoneSet.names).
    :param bone_parents: their parent links' names.
    :param grid: (G,2) the M9 grid bones' (row, column).
    """
    parents = np.array([skeleton.link_names.index(p) for p in bone_parents], dtype=np.int64)
    rest_j = rest_joints(skeleton, rig, parents, grid)
    names = list(skeleton.link_names) + list(bone_names)
    shape = _Shape(skeleton, rig, rest_j, grid)
    b = MeshBuilder()
    top = _lower_jacket(b, shape)
    _yoke_and_collar(b, shape, top)
    _sleeves(b, shape)
    _hood(b, shape)
    return b.done(names, floats(inverse(rest_j)))


class _Shape:
    """What the parts are sized and skinned from: the rig's body axes, joints and sizes."""

    def __init__(self, skeleton, rig, rest_j, grid):
        self.rig, self.rest_j = rig, rest_j
        self.n_links = len(skeleton.link_names)
        self.axes = rig.world_axes          # front, left, up of the body, simulation frame
        self.grid = {(int(r), int(c)): self.n_links + k for k, (r, c) in enumerate(grid)}
        self.hood_bone = self.n_links + len(grid)
        layer = rig.layer
        self.layer_base = self.hood_bone + 1
        self.upper = layer.upper_link if layer is not None and layer.pads else rig.pin_link
        self.pads = []                      # (pad bone, aim link, tip) per side
        if layer is not None and layer.pads:
            pose_ = layer.solve(skeleton.forward(np.zeros(len(skeleton.joint_names))))
            first = 2 * len(layer.sleeves)
            for k, pad in enumerate(layer.pads):
                self.pads.append((self.layer_base + first + k, pad.aim_link,
                                  pose_.tips[first + k]))
        self.sleeves = layer.sleeves if layer is not None else []

    def link_origin(self, link):
        return self.rest_j[link, :, 3]

    def local(self, p, centre):
        """(front, left, up) coordinates of a point from a centre."""
        return (np.asarray(p) - centre) @ self.axes

    def world(self, front, left, up, centre):
        return centre + self.axes @ np.array([front, left, up])


def _lower_jacket(b, s):
    """M3: the cloth grid subdivided round the body, skinned to the M9 bones; returns top row."""
    rig = s.rig
    rows, cols = rig.rows, rig.cols
    grid = rig.rest.reshape(rows, cols, 3)
    bone_cols = sorted({c for _, c in s.grid})
    n = (cols - 1) * SUBDIVIDE + 1
    index = np.empty((rows, n), dtype=int)
    for r in range(rows):
        for i in range(n):
            c = i / SUBDIVIDE
            index[r, i] = b.vertex(_catmull_rom(grid[r], c), _grid_weights(s, r, c, bone_cols))
    for r in range(rows - 1):
        b.quad_strip(index[r], index[r + 1], LOWER, lining=True)
    return index[0]


def _catmull_rom(row, c):
    """Return the point at column ``c`` (fractional) on the Catmull-Rom spline of a row."""
    n = len(row)
    i = min(int(np.floor(c)), n - 2)
    t = c - i
    p0, p1, p2, p3 = (row[max(i - 1, 0)], row[i], row[i + 1], row[min(i + 2, n - 1)])
    return 0.5 * ((2 * p1) + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t * t
                  + (-p0 + 3 * p1 - 3 * p2 + p3) * t ** 3)


def _grid_weights(s, r, c, bone_cols):
    """M9: bilinear between the grid bones round (row r, column c); the hem rides the row above."""
    last_row = s.rig.rows - 2
    rb = min(float(r), last_row)
    r0 = int(np.floor(rb))
    r1 = min(r0 + 1, last_row)
    fr = rb - r0
    k = np.searchsorted(bone_cols, c, side='right') - 1
    c0 = bone_cols[max(k, 0)]
    c1 = bone_cols[min(k + 1, len(bone_cols) - 1)]
    fc = 0.0 if c1 == c0 else (c - c0) / (c1 - c0)
    out = {}
    for row, wr in ((r0, 1 - fr), (r1, fr)):
        for col, wc in ((c0, 1 - fc), (c1, fc)):
            j = s.grid[(row, col)]
            out[j] = out.get(j, 0.0) + wr * wc
    return out


def _yoke_and_collar(b, s, top):
    """M2: from the cloth's top row up to the shoulders and in to the neck; the collar above."""
    rig = s.rig
    top_pts = np.array([b.points[i] for i in top])
    centre = top_pts.mean(axis=0)
    loc = np.array([s.local(p, centre) for p in top_pts])
    h0 = float(loc[:, 2].mean())
    neck = s.local(s.link_origin(rig.hood.link), centre)
    half_width = float(np.abs(loc[:, 1]).max())
    depth = float(np.abs(loc[:, 0]).max())
    if s.pads:
        tips = np.array([s.local(tip, centre) for _, _, tip in s.pads])
        shoulder = float(np.abs(tips[:, 1]).max())
        h_sh = float(tips[:, 2].mean())
    else:
        shoulder, h_sh = half_width, h0 + 0.5 * max(neck[2] - h0, 0.0)
    h_sh = max(h_sh, h0 + 0.02)
    h_neck = max(float(neck[2]), h_sh + 0.03)
    neck_r = 0.42 * depth
    # (height, front-back scale, half-width, share of the top row's weights, share on the pads)
    rings = ((h0 + 0.55 * (h_sh - h0), 1.0, 0.5 * (half_width + shoulder)),
             (h_sh, 0.92, shoulder),
             (h_sh + 0.45 * (h_neck - h_sh), 0.7, 0.55 * shoulder + 0.45 * neck_r))
    theta = np.arctan2(loc[:, 1] / max(half_width, 1e-9), loc[:, 0] / max(depth, 1e-9))
    cos_t, sin_t = np.cos(theta), np.sin(theta)
    upper_j, hood_link = s.upper, rig.hood.link
    prev = list(top)
    for k, (h, fscale, width) in enumerate(rings):
        ring = []
        for i in range(len(top)):
            p = s.world(depth * fscale * cos_t[i], width * sin_t[i], h, centre)
            inf = {upper_j: 1.0}
            side = sin_t[i]
            for pad_j, _, tip in s.pads:
                if np.sign(s.local(tip, centre)[1]) == np.sign(side) and abs(side) > 0.4:
                    share = (abs(side) - 0.4) / 0.6 * (0.8 if k < 2 else 0.4)
                    inf = {upper_j: 1.0 - share, pad_j: share}
            if k == 0:                       # the row above the cloth: partly the cloth's top
                inf = {j: 0.6 * w for j, w in inf.items()}
                for j, w in b.influences[top[i]].items():
                    inf[j] = inf.get(j, 0.0) + 0.4 * w
            ring.append(b.vertex(p, inf))
        b.quad_strip(ring, prev, YOKE, lining=True)
        prev = ring
    collar = ((h_neck, neck_r, 0.4), (h_neck + 0.05, 1.12 * neck_r, 0.7))
    for k, (h, r, w_neck) in enumerate(collar):
        ring = [b.vertex(s.world(r * cos_t[i], r * sin_t[i], h, centre),
                         {upper_j: 1.0 - w_neck, hood_link: w_neck}) for i in range(len(top))]
        b.quad_strip(ring, prev, COLLAR if k else YOKE, lining=True)
        prev = ring


def _sleeves(b, s):
    """M1: a tube round each arm chain, main to twist bone, bent at the elbow."""
    sleeves = s.sleeves
    if not sleeves:
        return
    ends = {sl.end_link for sl in sleeves if sl.end_link != sl.link}
    by_link = {sl.link: k for k, sl in enumerate(sleeves)}
    n_s = len(sleeves)
    for k, first in enumerate(sleeves):
        if first.link in ends:
            continue                          # not the start of a chain
        chain = [k]
        while (sleeves[chain[-1]].end_link in by_link and len(chain) < 4
               and sleeves[chain[-1]].end_link != sleeves[chain[-1]].link):
            chain.append(by_link[sleeves[chain[-1]].end_link])
        pad = [j for j, aim, _ in s.pads if aim == first.link]
        radius = float(np.clip(0.2 * first.length, 0.03, 0.09))
        rings = []
        for seg, idx in enumerate(chain):
            sl = sleeves[idx]
            main, twist = s.layer_base + idx, s.layer_base + n_s + idx
            start = s.link_origin(sl.link)
            axis = s.rest_j[sl.link, :, :3] @ sl.axis
            u, v = _perpendicular(axis, s.axes[:, 0])
            r_seg = radius * (0.82 if seg else 1.0)
            ts = ([-0.12, 0.12] if seg == 0 else []) + [0.35, 0.65, 0.9]
            if seg == len(chain) - 1:
                ts[-1] = 0.95                  # the cuff, short of the wrist
            for t in ts:
                inf = {main: 1.0 - t, twist: t} if t > 0 else {main: 1.0}
                if seg == 0 and t < 0.1 and pad:          # into the shoulder pad
                    inf = {main: 0.6, pad[0]: 0.4}
                if seg + 1 < len(chain) and t > 0.8:      # the bent bone at the elbow
                    nxt = s.layer_base + chain[seg + 1]
                    inf = {main: 0.5 * (1 - t), twist: 0.5 * t, nxt: 0.5}
                if seg > 0 and t < 0.2:
                    prev_twist = s.layer_base + n_s + chain[seg - 1]
                    inf = {main: 0.6, prev_twist: 0.4}
                taper = 1.0 - 0.15 * t if seg == len(chain) - 1 else 1.0
                centre = start + axis * (t * sl.length)
                rings.append([b.vertex(centre + r_seg * taper * (np.cos(a) * u + np.sin(a) * v),
                                       inf)
                              for a in np.linspace(0, 2 * np.pi, RING_SIDES, endpoint=False)])
            if seg + 1 < len(chain):           # the elbow ring, on both segments' bones
                nxt = chain[seg + 1]
                elbow = s.link_origin(sleeves[nxt].link)
                inf = {twist: 0.5, s.layer_base + nxt: 0.5}
                rings.append([b.vertex(elbow + 0.92 * r_seg * (np.cos(a) * u + np.sin(a) * v),
                                       inf)
                              for a in np.linspace(0, 2 * np.pi, RING_SIDES, endpoint=False)])
        for a, c in zip(rings, rings[1:]):
            b.quad_strip(c, a, SLEEVE, lining=False, closed=True)


def _perpendicular(axis, hint):
    """Two unit vectors across ``axis`` (right-handed with it), the first near ``hint``."""
    u = hint - axis * (hint @ axis)
    if np.linalg.norm(u) < 1e-6:
        other = [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0]
        u = np.cross(axis, other)
    u = u / np.linalg.norm(u)
    return u, np.cross(axis, u)


def _hood(b, s):
    """M8: a shell along the hood bone, behind the neck, its rim held by the hood's link."""
    rig = s.rig
    h = s.rest_j[s.hood_bone]
    x, y, z = h[:, 0], h[:, 1], h[:, 2]
    # z = x cross y points at the body (x runs back and down, y to the left): the shell bulges
    # the other way.
    if z @ s.axes[:, 0] < 0:
        z = -z
    length = 1.3 * rig.hood.length
    width = 0.6 * rig.hood.length
    anchor = h[:, 3]
    rows = []
    for r in range(HOOD_ROWS + 1):
        u = r / HOOD_ROWS
        w = width * max(np.sin(np.pi * (0.3 + 0.7 * u)) ** 0.7, 0.3)   # a rounded tip
        d = 0.55 * w
        neck = max(0.0, 0.6 * (1 - u / 0.4))
        inf = {s.hood_bone: 1.0 - neck, rig.hood.link: neck} if neck > 0 else {s.hood_bone: 1.0}
        ring = []
        for a in np.linspace(0.0, np.pi, HOOD_SIDES):
            p = anchor + x * (u * length - 0.15 * length) + y * (w * np.cos(a)) - z * (
                d * np.sin(a) + 0.02)
            ring.append(b.vertex(p, inf))
        rows.append(ring)
    for a, c in zip(rows, rows[1:]):
        b.quad_strip(a, c, HOOD, lining=True)


def posed_joints(links: np.ndarray, bone_parents: np.ndarray, bone_poses: np.ndarray
                 ) -> np.ndarray:
    """Return every joint of a mesh now (links, then bones), (J,3,4), in the simulation frame.

    :param links: (L,4,4) the link transforms (JacketSimulation.links).
    :param bone_parents: (B,) int64: each bone's parent link.
    :param bone_poses: (B,7) each bone in its parent's frame (JacketSimulation.bones().poses).
    """
    out = np.empty((len(links) + len(bone_parents), 3, 4))
    skinning.joint_matrices(floats(links), ints(bone_parents), floats(bone_poses), out)
    return out


def skinned(mesh: SkinnedMesh, joints: np.ndarray) -> np.ndarray:
    """Return the mesh's vertices (V,3) with its joints at ``joints`` (posed_joints).

    :param mesh: the mesh.
    :param joints: (J,3,4) every joint now, in the simulation frame.
    """
    out = np.empty(mesh.rest.shape)
    skinning.skin(floats(joints), mesh.inverse_rest, mesh.joints, mesh.weights, mesh.rest, out)
    return out
