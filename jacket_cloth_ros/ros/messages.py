# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""/tf, marker and diagnostic messages from the simulation's state, as CDR bytes (cdr.py).

The markers a person sees: the skinned jacket and hood (``jacket``), a triangle list of its outer
faces shaded per corner, on a simple body (``body``): its spheres and cylinders, which the viewer
lights. The method's scaffolding (the M3 grid, the M10 colliders, the M8 pendulum, the M1/M2
bones) is the debug layer, sent with ``markers_debug``.
"""

import functools
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.body_mesh import body_mesh, body_shapes
from ..core.geometry import grid_lines, grid_triangles
from . import cdr, marker_kernel
from ..core.bundles import MeshModel, Scene, flags, floats, ints
from ..core.compiled import FixedTypes
from ..core.jacket_mesh import LINING, SKIN, SkinnedMesh, jacket_mesh
from ..core.physics import skinning

if TYPE_CHECKING:           # for the annotations only
    from collections.abc import Callable

    from builtin_interfaces.msg import Time
    from ..core.rig import Rig
    from ..core.simulation import Bones, JacketSimulation

# visualization_msgs/Marker constants
SPHERE, CUBE, CYLINDER, LINE_LIST, TRIANGLE_LIST = 2, 1, 3, 5, 11
ADD, DELETEALL = 0, 3
# diagnostic_msgs/DiagnosticStatus levels
OK, WARN, ERROR = 0, 1, 2

# Every scene's bundles have the same types, so the marker kernel is typed once.
_FILL_MARKERS = FixedTypes(marker_kernel.fill_markers)
_MARKER_TABLE = FixedTypes(marker_kernel.marker_table)
_FILL_BODY = FixedTypes(marker_kernel.fill_body)
_DRAW = FixedTypes(skinning.draw)
_DRAW_POSED = FixedTypes(skinning.draw_posed)

DEBUG_NAMESPACES = ('cloth', 'colliders', 'hood', 'jacket_bones')
MESH_NAMESPACES = ('jacket',)      # triangle lists shaded per corner
MARKER_NAMESPACES = MESH_NAMESPACES + ('body',) + DEBUG_NAMESPACES
# The meshes' light, in the body's (front, left, up) axes: above, in front, a little left.
LIGHT = np.array([0.5, 0.3, 0.8]) / np.linalg.norm([0.5, 0.3, 0.8])
AMBIENT = 0.35
LINING_GAP = 0.003          # m: the lining drawn a cloth's thickness inside the jacket
TWEED = (0.42, 0.33, 0.24, 0.9)
SEAM = (0.2, 0.15, 0.1, 1.0)
GHOST = (0.4, 0.6, 0.9, 0.25)
HOOD = (0.55, 0.42, 0.3, 1.0)
IDENTITY = (0.0, 0.0, 0.0, 1.0)
# No planes to hold the drawn jacket out of (Outfit.draw_jacket).
NO_PLANES = (np.eye(4), np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)))


@dataclass
class MarkerSpec:
    ns: str
    id: int
    type: int
    action: int = ADD
    position: tuple = (0.0, 0.0, 0.0)
    orientation: tuple = IDENTITY
    scale: tuple = (1.0, 1.0, 1.0)
    color: tuple = (0.0, 0.0, 0.0, 0.0)
    points: np.ndarray = None
    lifetime_s: int = 1          # stale markers vanish if the node stops
    # Where a marker of marker_layout takes its varying values from (see marker_values):
    pose_row: int = -1           # its position, orientation and scale: this row of the poses
    point_rows: np.ndarray = None  # its points: these rows of the point table
    mesh: str = ''               # a shaded mesh of Outfit (``jacket``, ``body``): its corners
    mesh_points: int = 0         # how many corners (3 per triangle)
    colors: np.ndarray = None    # (P,4) one per point


def stamp_msg(stamp_ns: int) -> 'Time':
    """Return a builtin_interfaces/Time message of a time.

    :param stamp_ns: the time, ns.
    """
    from builtin_interfaces.msg import Time
    return Time(sec=int(stamp_ns // 1_000_000_000), nanosec=int(stamp_ns % 1_000_000_000))


def tf_message(bones: 'Bones', stamp_ns: int, prefix: str = '') -> bytes:
    """One TFMessage with every bone, each a child of an existing skeleton link.

    :param bones: the bones, their poses in their parents' frames.
    :param stamp_ns: every transform's stamp, ns.
    :param prefix: put before every frame name (as robot_state_publisher's ``frame_prefix``).
    """
    return tf_template(tuple(bones.names), tuple(bones.parents), prefix).encode(
        bones.poses, stamp_ns)


@functools.lru_cache(maxsize=8)
def tf_template(names: tuple[str, ...], parents: tuple[str, ...],
                prefix: str) -> cdr.TfTemplate:
    """Return the TFMessage layout of these bones (cdr.TfTemplate); ``encode(poses, stamp_ns)``.

    :param names: the bones' frame names.
    :param parents: each bone's parent frame.
    :param prefix: goes on bones and parents alike, as robot_state_publisher's ``frame_prefix``
        goes on every link: two characters with their own prefixes are two trees.
    """
    return cdr.TfTemplate(names, tuple(prefix + p for p in parents), prefix)


class Outfit:
    """The meshes of a rig: the jacket and hood, and the body (core.jacket_mesh, body_mesh).

    The markers draw the jacket's mesh and the body's pieces; pictures and export both meshes.

    :param rig: the character's rig.
    :param bone_names: the published bones (simulation.BoneSet), the jacket's joints.
    :param bone_parents: their parent links' names.
    :param grid: (G,2) the M9 grid bones' (row, column).
    """

    def __init__(self, rig: 'Rig', bone_names: list, bone_parents: list, grid: np.ndarray):
        skeleton = rig.skeleton
        self.jacket = jacket_mesh(skeleton, rig, bone_names, bone_parents, grid)
        self.body_shapes = body_shapes(skeleton, rig)
        self.body = body_mesh(skeleton, rig, self.body_shapes)
        self.bone_parents = np.array([skeleton.link_names.index(p) for p in bone_parents],
                                     dtype=np.int64)
        self.light = floats(rig.world_axes @ LIGHT)
        self._models = {name: _mesh_model(m, np.ones(len(m.triangles), bool))
                        for name, m in self.meshes().items()}
        # RViz and Foxglove draw both sides of a triangle list, so the live jacket needs no
        # lining: its outer faces alone, drawn from inside too, at three fifths of the bytes.
        self.outer = ~self.jacket.back
        self._outer_model = _mesh_model(self.jacket, self.outer)

    def meshes(self) -> dict[str, SkinnedMesh]:
        """Return the meshes by marker namespace."""
        return {'jacket': self.jacket, 'body': self.body}

    def corners(self, name: str) -> int:
        """Return how many triangle-list points a mesh drawn whole has (:meth:`triangles`).

        The live jacket's marker has :meth:`marker_corners`.

        :param name: ``jacket`` or ``body``.
        """
        return 3 * len(self.meshes()[name].triangles)

    def marker_corners(self) -> int:
        """Return how many points the live jacket's triangle list has (its outer faces)."""
        return 3 * int(self.outer.sum())

    def lined(self, corners: np.ndarray, colors: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the live jacket's triangles with the lining put back, as pictures draw it.

        Each lined outer face gets its back face after it, as :meth:`draw` orders them: wound
        the other way, ``LINING_GAP`` inside along the face's own normal, in the lining's
        colour lit from its side, one shade per face (draw moves and lights each vertex by its
        averaged normal; the recorded corners carry no normals).

        :param corners: (:meth:`marker_corners`,3) the markers' jacket (:meth:`draw_jacket`).
        :param colors: (:meth:`marker_corners`,4) their colours.
        :returns: (T,3,3) triangles and (T,4) their colours, each the mean of its corners'.
        """
        tris = corners.reshape(-1, 3, 3)
        face = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        face /= np.maximum(np.linalg.norm(face, axis=1), 1e-12)[:, None]
        shade = AMBIENT + (1.0 - AMBIENT) * np.maximum(-face @ self.light, 0.0)
        inside = tris[:, [0, 2, 1]] - LINING_GAP * face[:, None, :]
        lining = np.array(LINING) * np.stack([shade] * 3 + [np.ones_like(shade)], axis=1)
        # A front face is lined when its back face follows it in the jacket's triangles.
        back = self.jacket.back
        has = np.append(back[1:], False)[~back]
        out = np.empty((len(tris) + has.sum(), 3, 3))
        out_colors = np.empty((len(out), 4))
        at = np.arange(len(tris)) + np.cumsum(has) - has
        out[at], out_colors[at] = tris, colors.reshape(-1, 3, 4).mean(axis=1)
        out[at[has] + 1], out_colors[at[has] + 1] = inside[has], lining[has]
        return out, out_colors

    def triangles(self, name: str, joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return a mesh skinned and shaded on ``joints``: its corners and their colours.

        :param name: ``jacket`` or ``body``.
        :param joints: (J,3,4) every joint now (the body's: the skeleton's links).
        :returns: (3T,3) corners, (3T,4) float32 colours.
        """
        n = self.corners(name)
        points, colors = np.empty((n, 3)), np.empty((n, 4), dtype=np.float32)
        self.draw(name, joints, points, colors)
        return points, colors

    def draw_jacket(self, links: np.ndarray, bone_poses: np.ndarray, points: np.ndarray,
                    colors: np.ndarray, planes: tuple = NO_PLANES) -> None:
        """Pose the jacket's joints and :meth:`draw` its outer faces, in one compiled call.

        The markers' jacket: the outer faces of :meth:`triangles`, in their order.

        :param links: (L,4,4) the links now (JacketSimulation.links).
        :param bone_poses: (B,7) the published bones, each in its parent's frame.
        :param points: (:meth:`marker_corners`,3) written: the corners.
        :param colors: (:meth:`marker_corners`,4) float32 written: their shaded colours.
        :param planes: the rig's planes the skinned jacket is held out of
            (:func:`jacket_planes`); none: as an exported file's viewer skins it.
        """
        _DRAW_POSED(self._outer_model, floats(links), self.bone_parents,
                    floats(bone_poses), self.light, AMBIENT, LINING_GAP, planes, points, colors)

    def draw(self, name: str, joints: np.ndarray, points: np.ndarray,
             colors: np.ndarray) -> None:
        """Skin, shade and lay out a mesh as a triangle list into ``points`` and ``colors``.

        :param name: ``jacket`` or ``body``.
        :param joints: (J,3,4) every joint now (core.jacket_mesh.posed_joints).
        :param points: (3T,3) written: the corners.
        :param colors: (3T,4) float32 written: their shaded colours.
        """
        _DRAW(self._models[name], floats(joints), self.light, AMBIENT, LINING_GAP, points,
              colors)


def jacket_planes(sim: 'JacketSimulation') -> tuple:
    """Return the planes the drawn jacket is held out of: the rig's, seen from ``sim.root``.

    As physics.skinning.above_planes takes them (posed on the links it draws on).

    :param sim: the simulation, after its last step.
    """
    c = sim.model.colliders
    return floats(sim.root), c.plane_links, c.plane_points, c.plane_normals


def _mesh_model(mesh, keep):
    """Return the compiled draw's model of a mesh's triangles ``keep``."""
    return MeshModel(floats(mesh.inverse_rest), ints(mesh.joints), floats(mesh.weights),
                     floats(mesh.rest), ints(mesh.triangles[keep]),
                     ints(mesh.triangles[~mesh.back]), floats(mesh.colors[keep]),
                     flags(mesh.back[keep]))


@functools.lru_cache(maxsize=16)
def outfit(rig: 'Rig') -> Outfit:
    """Return the rig's meshes, built once per rig.

    :param rig: the character's rig.
    """
    from ..core.simulation import bone_set
    bones = bone_set(rig.skeleton, rig)
    return Outfit(rig, bones.names, bones.parents, bones.grid)


@functools.lru_cache(maxsize=16)
def marker_layout(rig: 'Rig', layer_bones: int, reset: bool, debug: bool = False,
                  body: bool = True) -> tuple[MarkerSpec, ...]:
    """Lay out every marker of the rig but its varying values.

    The jacket and hood mesh and the body (``jacket``, ``body``), then with ``debug`` the
    method's scaffolding: cloth grid and seams, colliders, hood pendulum, M1/M2 bones.

    :param rig: the character's rig.
    :param layer_bones: how many M1/M2 bones.
    :param reset: whether a DELETEALL goes first in each namespace (after a reset).
    :param debug: add the scaffolding.
    :param body: add the body.
    """
    out = [MarkerSpec(ns, 0, 0, action=DELETEALL, lifetime_s=0)
           for ns in MARKER_NAMESPACES] if reset else []
    meshes = outfit(rig)
    out.append(MarkerSpec('jacket', 0, TRIANGLE_LIST, color=(1.0, 1.0, 1.0, 1.0), mesh='jacket',
                          mesh_points=meshes.marker_corners()))
    if body:
        # Solids, a small share of a triangle list's bytes; the pose table's rows after the
        # debug layer's.
        shapes = meshes.body_shapes
        first = marker_kernel.shape_count(rig)
        kinds = [SPHERE] * len(shapes.links) + [CYLINDER, SPHERE, SPHERE] * len(
            shapes.capsule_links)
        out.extend(MarkerSpec('body', k, kind, color=SKIN, pose_row=first + k)
                   for k, kind in enumerate(kinds))
    if debug:
        out.extend(_debug_layout(rig, layer_bones))
    return tuple(out)


def _debug_layout(rig, layer_bones):
    """Return the scaffolding's markers: cloth grid and seams, colliders, pendulum, bones."""
    out = []
    n = rig.n
    out.append(MarkerSpec('cloth', 0, TRIANGLE_LIST, color=TWEED,
                          point_rows=grid_triangles(rig.rows, rig.cols)))
    out.append(MarkerSpec('cloth', 1, LINE_LIST, scale=(0.004, 1.0, 1.0), color=SEAM,
                          point_rows=grid_lines(rig.rows, rig.cols)))
    shapes = ([SPHERE] * len(rig.collider_links) + [CYLINDER, SPHERE, SPHERE] * len(
        rig.capsule_links) + [CUBE] * len(rig.plane_links))
    for k, kind in enumerate(shapes):
        out.append(MarkerSpec('colliders', k, kind, color=GHOST, pose_row=k))
    out.append(MarkerSpec('hood', 0, LINE_LIST, scale=(0.01, 1.0, 1.0), color=HOOD,
                          point_rows=np.array([n, n + 1])))          # anchor to particle
    out.append(MarkerSpec('hood', 1, SPHERE, color=HOOD, pose_row=len(shapes)))
    if layer_bones:
        # Segments from each bone's pivot to its tip.
        pivots = np.arange(layer_bones) + n + 2
        out.append(MarkerSpec('jacket_bones', 0, LINE_LIST, scale=(0.012, 1.0, 1.0),
                              color=SEAM, point_rows=np.stack([pivots, pivots + layer_bones], 1)
                              .reshape(-1)))
    return out


def marker_values(sim: 'JacketSimulation') -> tuple[np.ndarray, np.ndarray]:
    """Return (poses, points): the pose table and the point table.

    The pose table as marker_kernel.shape_poses makes it; the point table holds the cloth's
    vertices, the hood's anchor and particle, the layer bones' pivots and their tips.

    :param sim: the simulation, after its last step.
    """
    table, rows = _MARKER_TABLE(*_marker_arguments(sim))
    width = marker_kernel.POSE_WIDTH
    return table[:rows * width].reshape(rows, width), table[rows * width:].reshape(-1, 3)


def _marker_arguments(sim):
    layer = sim.layer
    empty = np.empty((0, 3))
    return (sim.model, Scene(floats(sim.links), floats(sim.root), floats(sim.x),
                             floats(sim.hood_p),
                             empty if layer is None else floats(layer.positions),
                             empty if layer is None else floats(layer.tips)),
            outfit(sim.rig).body_shapes)


def _layer_bones(sim):
    return 0 if sim.layer is None else len(sim.layer.positions)


def marker_specs(sim: 'JacketSimulation', reset: bool = False, debug: bool = False,
                 body: bool = True) -> list[MarkerSpec]:
    """Return the MarkerArray's markers with their values: what marker_array encodes, readable.

    :param sim: the simulation, after its last step.
    :param reset: whether a DELETEALL goes first in each namespace (after a reset).
    :param debug: add the method's scaffolding (see marker_layout).
    :param body: add the body.
    """
    poses, points = marker_values(sim)
    meshes = outfit(sim.rig)
    out = []
    for m in marker_layout(sim.rig, _layer_bones(sim), reset, debug, body):
        if m.mesh:
            corners = np.empty((m.mesh_points, 3))
            colors = np.empty((m.mesh_points, 4), dtype=np.float32)
            meshes.draw_jacket(sim.links, sim.bones().poses, corners, colors,
                               jacket_planes(sim))
            m = replace(m, points=corners, colors=colors)
        if m.pose_row >= 0:
            row = poses[m.pose_row].tolist()
            m = replace(m, position=tuple(row[:3]), orientation=tuple(row[3:7]),
                        scale=tuple(row[7:]))
        if m.point_rows is not None:
            m = replace(m, points=points[m.point_rows])
        out.append(m)
    return out


def marker_array(sim: 'JacketSimulation', stamp_ns: int, frame: str,
                 reset: bool = False, debug: bool = False, body: bool = True,
                 draw_jacket: 'Callable | None' = None) -> bytes:
    """Return the MarkerArray's CDR bytes: its values written into a template laid out once.

    :param sim: the simulation, after its last step.
    :param stamp_ns: every marker's stamp, ns.
    :param frame: every marker's frame.
    :param reset: whether a DELETEALL goes first in each namespace (after a reset).
    :param debug: add the method's scaffolding (see marker_layout).
    :param body: add the body.
    :param draw_jacket: what skins the jacket into the message, called as
        :meth:`Outfit.draw_jacket`; None: the rig's outfit's own. A profiler passes it timed
        (SessionPipeline's ``stage_timer``), so the outfit the rig's pipelines share is left
        as it is.
    """
    template = _marker_template(sim.rig, _layer_bones(sim), reset, frame, debug, body)
    if template.meshes:
        points, colors = template.meshes['jacket']
        (draw_jacket or outfit(sim.rig).draw_jacket)(sim.links, sim.bones().poses, points,
                                                     colors, jacket_planes(sim))
    if debug:
        return template.encode(_FILL_MARKERS, _marker_arguments(sim), stamp_ns)
    return template.encode(_FILL_BODY, (floats(sim.links), outfit(sim.rig).body_shapes,
                                        marker_kernel.shape_count(sim.rig)), stamp_ns)


@functools.lru_cache(maxsize=16)
def _marker_template(rig, layer_bones, reset, frame, debug, body):
    """One per layout: the reset array, with its DELETEALLs in front, is another."""
    rows = marker_kernel.shape_count(rig) + marker_kernel.body_count(outfit(rig).body_shapes)
    return cdr.MarkerTemplate(marker_layout(rig, layer_bones, reset, debug, body), frame, rows)


def diagnostics(stamp_ns: int, node_name: str, values: dict, level: int,
                message: str) -> bytes:
    """Encode the node's one DiagnosticArray status.

    :param stamp_ns: the array's stamp, ns.
    :param node_name: the node's name, in the status's name.
    :param values: the status's key-value pairs.
    :param level: OK, WARN or ERROR.
    :param message: the status's one line.
    """
    status = (level, f'{node_name}: cloth simulation', message, 'jacket_cloth', values)
    return cdr.diagnostic_array(stamp_ns, [status])
