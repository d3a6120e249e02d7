# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""/tf, marker and diagnostic messages from the simulation's state, as CDR bytes (cdr.py)."""

import functools
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..core.geometry import grid_lines, grid_triangles
from . import cdr, marker_kernel
from ..core.bundles import Scene, floats
from ..core.compiled import FixedTypes

if TYPE_CHECKING:           # for the annotations only
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

MARKER_NAMESPACES = ('cloth', 'colliders', 'hood', 'jacket_bones')
TWEED = (0.42, 0.33, 0.24, 0.9)
SEAM = (0.2, 0.15, 0.1, 1.0)
GHOST = (0.4, 0.6, 0.9, 0.25)
HOOD = (0.55, 0.42, 0.3, 1.0)
IDENTITY = (0.0, 0.0, 0.0, 1.0)


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


@functools.lru_cache(maxsize=8)
def marker_layout(rig: 'Rig', layer_bones: int, reset: bool) -> tuple[MarkerSpec, ...]:
    """Lay out every marker of the rig but its varying values.

    Cloth mesh and seams, colliders, hood pendulum, M1/M2 bones.

    :param rig: the character's rig.
    :param layer_bones: how many M1/M2 bones.
    :param reset: whether a DELETEALL goes first in each namespace (after a reset).
    """
    out = [MarkerSpec(ns, 0, 0, action=DELETEALL, lifetime_s=0)
           for ns in MARKER_NAMESPACES] if reset else []
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
    return tuple(out)


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
                             empty if layer is None else floats(layer.tips)))


def _layer_bones(sim):
    return 0 if sim.layer is None else len(sim.layer.positions)


def marker_specs(sim: 'JacketSimulation', reset: bool = False) -> list[MarkerSpec]:
    """Return the MarkerArray's markers with their values: what marker_array encodes, readable.

    :param sim: the simulation, after its last step.
    :param reset: whether a DELETEALL goes first in each namespace (after a reset).
    """
    poses, points = marker_values(sim)
    out = []
    for m in marker_layout(sim.rig, _layer_bones(sim), reset):
        if m.pose_row >= 0:
            row = poses[m.pose_row].tolist()
            m = replace(m, position=tuple(row[:3]), orientation=tuple(row[3:7]),
                        scale=tuple(row[7:]))
        if m.point_rows is not None:
            m = replace(m, points=points[m.point_rows])
        out.append(m)
    return out


def marker_array(sim: 'JacketSimulation', stamp_ns: int, frame: str,
                 reset: bool = False) -> bytes:
    """Return the MarkerArray's CDR bytes: its values written into a template laid out once.

    :param sim: the simulation, after its last step.
    :param stamp_ns: every marker's stamp, ns.
    :param frame: every marker's frame.
    :param reset: whether a DELETEALL goes first in each namespace (after a reset).
    """
    template = _marker_template(sim.rig, _layer_bones(sim), reset, frame)
    return template.encode(_FILL_MARKERS, _marker_arguments(sim), stamp_ns)


@functools.lru_cache(maxsize=8)
def _marker_template(rig, layer_bones, reset, frame):
    """One per layout: the reset array, with its DELETEALLs in front, is another."""
    return cdr.MarkerTemplate(marker_layout(rig, layer_bones, reset), frame,
                              marker_kernel.shape_count(rig))


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
