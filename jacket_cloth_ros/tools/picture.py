# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A filmstrip of a recorded session: skeleton, jacket and hood at chosen moments.

Drawn from what the node published: the cloth mesh, hood and jacket bones from the recorded
markers, the skeleton from the recorded JointState through the same forward kinematics the node
used. The response is shown against the skinned pose the simulation starts from (dashed: the
jacket's reference hem and the hood at rest, as the rig puts them for that skeleton pose): the
gap between dashed and solid is what the cloth and the pendulum add.
"""

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from visualization_msgs.msg import Marker, MarkerArray  # noqa: E402

from ..core.fabric import load_fabric  # noqa: E402
from ..core.inputs import InputParser  # noqa: E402
from ..core.simulation import JacketSimulation  # noqa: E402
from ..recording.reader import read_messages  # noqa: E402

VIEWS = (('side', 0, 'x (m, forward)'), ('front', 1, 'y (m, left)'))


def _stamp(msg):
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def _markers_by_time(messages):
    out = []
    for m in messages:
        if m.type_name.endswith('MarkerArray'):
            arr = deserialize_message(m.data, MarkerArray)
            mesh = [k for k in arr.markers if k.ns == 'cloth' and k.id == 0
                    and k.action == Marker.ADD]
            hood = [k for k in arr.markers if k.ns == 'hood' and k.id == 0
                    and k.action == Marker.ADD]
            bones = [k for k in arr.markers if k.ns == 'jacket_bones' and k.id == 0
                     and k.action == Marker.ADD]
            if mesh and hood:
                tri = np.array([[p.x, p.y, p.z] for p in mesh[0].points]).reshape(-1, 3, 3)
                rod = np.array([[p.x, p.y, p.z] for p in hood[0].points])
                segments = np.array([[p.x, p.y, p.z] for p in bones[0].points]).reshape(
                    -1, 2, 3) if bones else np.zeros((0, 2, 3))
                out.append((m.log_time, tri, rod, segments))
    return out


def _skinned(sim, links):
    """The reference hem (M11 reference points of the last row) and the hood at rest."""
    layer = sim._solve_layer(links)
    ref = sim.reference_points(links, layer).reshape(sim.rig.rows, sim.rig.cols, 3)
    anchor, rot = sim.hood_anchor(links)
    hood = np.array([anchor, anchor + rot @ sim.rig.hood.rest_direction * sim.rig.hood.length])
    return ref[-1], hood


def render_filmstrip(mcap_path, png_path, skeleton, moments=6, labels=None, title=None,
                     times=None, rig=None):
    """Write a PNG of the session at ``times`` (s from its start) or at ``moments`` evenly
    spaced instants; returns the stamps drawn. With ``rig``, the skinned pose is drawn too."""
    messages, _ = read_messages(mcap_path)
    frames = _markers_by_time(messages)
    states = [deserialize_message(m.data, JointState) for m in messages
              if m.type_name.endswith('JointState')]
    if not frames or not states:
        raise ValueError(f'{mcap_path}: no markers or JointState to draw')
    t0 = _stamp(states[0])
    if times is None:
        picks = np.linspace(0, len(frames) - 1, moments + 2)[1:-1].astype(int)
    else:
        stamps = np.array([f[0] for f in frames])
        picks = [int(np.argmin(np.abs(stamps - (t0 + t * 1e9)))) for t in times]
    moments = len(picks)
    parser = InputParser(skeleton)
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket')) if rig else None
    fig, axes = plt.subplots(2, moments, figsize=(2.6 * moments, 7.2), squeeze=False)
    chosen = []
    for col, k in enumerate(picks):
        stamp, tri, rod, segments = frames[k]
        js = min(states, key=lambda s: abs(_stamp(s) - stamp))
        sample = parser.parse(_stamp(js), js.name, js.position)
        poses = skeleton.forward(sample.q)
        links = poses[:, :3, 3]
        hem, hood_rest = _skinned(sim, poses) if sim else (None, None)
        chosen.append(stamp)
        for row, (view, axis, xlabel) in enumerate(VIEWS):
            ax = axes[row][col]
            for i in range(1, len(links)):
                p = links[[skeleton.parent[i], i]]
                ax.plot(p[:, axis], p[:, 2], color='0.25', lw=2.5, solid_capstyle='round')
            ax.add_collection(matplotlib.collections.PolyCollection(
                tri[:, :, [axis, 2]], facecolor=(0.45, 0.35, 0.25, 0.55),
                edgecolor=(0.25, 0.18, 0.12, 0.8), lw=0.4))
            for seg in segments:
                ax.plot(seg[:, axis], seg[:, 2], color=(0.15, 0.1, 0.35), lw=2)
            ax.plot(rod[:, axis], rod[:, 2], color=(0.75, 0.3, 0.1), lw=3)
            ax.plot(rod[1, axis], rod[1, 2], 'o', color=(0.75, 0.3, 0.1), ms=7)
            if hem is not None:
                ax.plot(hem[:, axis], hem[:, 2], '--', color=(0.2, 0.2, 0.8), lw=1.2)
                ax.plot(hood_rest[:, axis], hood_rest[:, 2], '--', color=(0.2, 0.2, 0.8),
                        lw=1.2)
            ax.set_xlim(-0.7, 0.7)
            ax.set_ylim(-1.0, 1.3)
            ax.set_aspect('equal')
            ax.grid(alpha=0.3)
            ax.set_xlabel(xlabel, fontsize=8)
            ax.tick_params(labelsize=7)
            if col == 0:
                ax.set_ylabel(f'{view} view: z (m, up)', fontsize=8)
            if row == 0:
                name = labels(stamp - t0) if labels else ''
                ax.set_title(f't = {(stamp - t0) * 1e-9:.1f} s {name}', fontsize=9)
    fig.suptitle(title or 'jacket (brown), hood pendulum (orange) and jacket bones (navy) on '
                 'the skeleton, character frame; dashed blue: skinned hem and hood at rest',
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)
    return chosen
