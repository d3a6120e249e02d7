# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A filmstrip of a session: skeleton, jacket, hood and jacket bones at chosen moments.

Frames come either from a recording (the cloth mesh, hood and jacket bones as the node
published them on ~/markers, the skeleton from the recorded JointState through the same forward
kinematics) or straight from a simulation being run (the analysis). The response is drawn
against the skinned pose the simulation starts from (dashed: the jacket's reference hem and the
hood at rest for that skeleton pose): the gap between dashed and solid is what the cloth and
the pendulum add.
"""

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from ..core.fabric import load_fabric  # noqa: E402
from ..core.geometry import grid_triangles  # noqa: E402
from ..core.inputs import InputParser  # noqa: E402
from ..core.simulation import JacketSimulation  # noqa: E402
from ..recording.reader import read_messages  # noqa: E402

if TYPE_CHECKING:           # for the annotations only
    from ..core.rig import Rig
    from ..core.skeleton import Skeleton

VIEWS = (('side', 0, 'x (m, forward)'), ('front', 1, 'y (m, left)'))


@dataclass
class Frame:
    stamp_ns: int
    triangles: np.ndarray       # (T,3,3) cloth mesh
    hood: np.ndarray            # (2,3) anchor and particle
    bones: np.ndarray           # (B,2,3) jacket bone segments
    links: np.ndarray           # (L,3) skeleton link origins
    hem_ref: np.ndarray = None  # (C,3) skinned hem
    hood_ref: np.ndarray = None  # (2,3) hood at rest


def sim_frame(sim: JacketSimulation, stamp_ns: int) -> Frame:
    """Return a frame of a running simulation (its current state)."""
    rig = sim.rig
    layer = sim.layer
    ref = sim.reference_points(sim.links, layer).reshape(rig.rows, rig.cols, 3)
    anchor, rot = sim.hood_anchor(sim.links)
    rest = anchor + rot @ rig.hood.rest_direction * rig.hood.length
    bones = np.stack([layer.positions, layer.tips], axis=1) if layer else np.zeros((0, 2, 3))
    return Frame(stamp_ns, sim.x[grid_triangles(rig.rows, rig.cols)].reshape(-1, 3, 3),
                 np.array([anchor, sim.hood_p]), bones, sim.links[:, :3, 3].copy(),
                 ref[-1].copy(), np.array([anchor, rest]))


def _stamp(msg):
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def recorded_frames(mcap_path: str, skeleton: 'Skeleton',
                    rig: 'Rig | None' = None) -> tuple[list[Frame], int]:
    """Frames at every recorded MarkerArray with a mesh; the skeleton from the nearest input."""
    messages, _ = read_messages(mcap_path)
    states = [deserialize_message(m.data, JointState) for m in messages
              if m.type_name.endswith('JointState')]
    parser = InputParser(skeleton)
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket')) if rig else None
    out = []
    for m in messages:
        if not m.type_name.endswith('MarkerArray'):
            continue
        arr = deserialize_message(m.data, MarkerArray)
        found = {(k.ns, k.id): k for k in arr.markers if k.action == Marker.ADD}
        if ('cloth', 0) not in found or ('hood', 0) not in found:
            continue
        pts = {key: np.array([[p.x, p.y, p.z] for p in k.points]) for key, k in found.items()}
        bones = pts.get(('jacket_bones', 0), np.zeros((0, 3))).reshape(-1, 2, 3)
        js = min(states, key=lambda s: abs(_stamp(s) - m.log_time))
        poses = skeleton.forward(parser.parse(_stamp(js), js.name, js.position).q)
        frame = Frame(m.log_time, pts[('cloth', 0)].reshape(-1, 3, 3), pts[('hood', 0)], bones,
                      poses[:, :3, 3])
        if sim is not None:
            sim.links = poses          # the skinned pose of this skeleton pose
            skinned = sim_frame(sim, m.log_time)
            frame.hem_ref, frame.hood_ref = skinned.hem_ref, skinned.hood_ref
        out.append(frame)
    if not out or not states:
        raise ValueError(f'{mcap_path}: no markers or JointState to draw')
    return out, _stamp(states[0])


def pick(frames: list[Frame], t0: int, times: Sequence[float] | None = None,
         moments: int = 6) -> list[Frame]:
    """Frames nearest ``times`` (s after t0), or ``moments`` evenly spaced ones."""
    if times is None:
        picks = np.linspace(0, len(frames) - 1, moments + 2)[1:-1].astype(int)
    else:
        stamps = np.array([f.stamp_ns for f in frames])
        picks = [int(np.argmin(np.abs(stamps - (t0 + t * 1e9)))) for t in times]
    return [frames[k] for k in picks]


def draw_filmstrip(frames: list[Frame], skeleton: 'Skeleton | Sequence[Skeleton]', png_path: str,
                   t0: int, labels: Callable[[int], str] | None = None,
                   title: str | None = None, columns: Sequence[str] | None = None) -> None:
    """Two rows (side and front view), one column per frame.

    ``skeleton``: one for every frame, or one per frame (a crowd's characters side by side,
    each column titled by ``columns``).
    """
    skeletons = list(skeleton) if isinstance(skeleton, (list, tuple)) else [skeleton] * len(
        frames)
    fig, axes = plt.subplots(2, len(frames), figsize=(2.6 * len(frames), 7.2), squeeze=False)
    for col, f in enumerate(frames):
        for row, (view, axis, xlabel) in enumerate(VIEWS):
            ax = axes[row][col]
            for i in range(1, len(f.links)):
                p = f.links[[skeletons[col].parent[i], i]]
                ax.plot(p[:, axis], p[:, 2], color='0.25', lw=2.5, solid_capstyle='round')
            ax.add_collection(matplotlib.collections.PolyCollection(
                f.triangles[:, :, [axis, 2]], facecolor=(0.45, 0.35, 0.25, 0.55),
                edgecolor=(0.25, 0.18, 0.12, 0.8), lw=0.4))
            for seg in f.bones:
                ax.plot(seg[:, axis], seg[:, 2], color=(0.15, 0.1, 0.35), lw=2)
            ax.plot(f.hood[:, axis], f.hood[:, 2], color=(0.75, 0.3, 0.1), lw=3)
            ax.plot(f.hood[1, axis], f.hood[1, 2], 'o', color=(0.75, 0.3, 0.1), ms=7)
            for ref in (f.hem_ref, f.hood_ref):
                if ref is not None:
                    ax.plot(ref[:, axis], ref[:, 2], '--', color=(0.2, 0.2, 0.8), lw=1.2)
            ax.set_xlim(-0.7, 0.7)
            ax.set_ylim(-1.0, 1.3)
            ax.set_aspect('equal')
            ax.grid(alpha=0.3)
            ax.set_xlabel(xlabel, fontsize=8)
            ax.tick_params(labelsize=7)
            if col == 0:
                ax.set_ylabel(f'{view} view: z (m, up)', fontsize=8)
            if row == 0 and columns:
                ax.set_title(columns[col], fontsize=9)
            elif row == 0:
                name = labels(f.stamp_ns - t0) if labels else ''
                ax.set_title(f't = {(f.stamp_ns - t0) * 1e-9:.1f} s {name}', fontsize=9)
    fig.suptitle(title or 'jacket (brown), hood pendulum (orange) and jacket bones (navy) on '
                 'the skeleton, character frame; dashed blue: skinned hem and hood at rest',
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)


def render_filmstrip(mcap_path: str, png_path: str, skeleton: 'Skeleton', moments: int = 6,
                     labels: Callable[[int], str] | None = None, title: str | None = None,
                     times: Sequence[float] | None = None,
                     rig: 'Rig | None' = None) -> list[int]:
    """Draw a filmstrip of a recording; return the stamps drawn.

    At ``times`` (s from its start) or ``moments`` evenly spaced instants; with ``rig``, the
    skinned pose is drawn too.
    """
    frames, t0 = recorded_frames(mcap_path, skeleton, rig)
    chosen = pick(frames, t0, times, moments)
    draw_filmstrip(chosen, skeleton, png_path, t0, labels, title)
    return [f.stamp_ns for f in chosen]
