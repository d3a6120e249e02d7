# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""A filmstrip of a session: the jacket and hood on the body at chosen moments.

Frames come either from a recording (the skinned jacket and body as the node published them on
~/markers, the skeleton from the recorded JointState through the same forward kinematics) or
straight from a simulation being run (the analysis). By default a frame is the shaded jacket
and hood on the shaded body, drawn back to front with hidden faces left out. The ``debug``
style draws the method instead: the stick figure, the cloth grid, the hood pendulum and the
jacket bones against the skinned pose the simulation starts from (dashed: the jacket's
reference hem and the hood at rest for that skeleton pose), the gap between dashed and solid
being what the cloth and the pendulum add; a recording has that only with ``markers_debug``.

Frames are drawn in the world, whatever the URDF's link axes: the root's world pose (the world
joint of the input) carries them out of the character's frame, the rig's ``up`` is drawn up and
its ``forward`` to the right of the side view, and each frame is centred on the character's
body link (the first link from the root with two children or more: the pelvis) at its moment,
so a character that walks away, by the world joint or by the URDF's own joints, stays in frame.
"""

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from visualization_msgs.msg import Marker  # noqa: E402

from ..core.bundles import floats  # noqa: E402
from ..core.fabric import load_fabric  # noqa: E402
from ..core.geometry import grid_triangles  # noqa: E402
from ..core.inputs import InputParser  # noqa: E402
from ..core.rig import body_axes  # noqa: E402
from ..core.simulation import JacketSimulation  # noqa: E402
from ..recording.reader import each_message  # noqa: E402
from ..ros import messages  # noqa: E402
from ..ros.cdr import DECODE_ERRORS, JointStateReader, read_markers  # noqa: E402

if TYPE_CHECKING:           # for the annotations only
    from ..core.rig import Rig
    from ..core.skeleton import Skeleton

JOINT_STATE, MARKER_ARRAY = 'sensor_msgs/msg/JointState', 'visualization_msgs/msg/MarkerArray'
VIEWS = (('side', 0), ('front', 1))     # the view axis drawn across: forward, left
WORLD_AXES = body_axes([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], 'rig')    # z up, x forward


STYLES = ('jacket', 'debug')
DEFAULT_TITLES = {'jacket': 'the jacket and hood, skinned on the simulated bones',
                  'debug': 'jacket grid (brown), hood pendulum (orange), jacket bones (navy);\n'
                           'dashed blue: skinned hem and hood at rest'}


@dataclass
class Frame:
    stamp_ns: int
    triangles: np.ndarray       # (T,3,3) cloth grid mesh (debug)
    hood: np.ndarray            # (2,3) anchor and particle (debug)
    bones: np.ndarray           # (B,2,3) jacket bone segments (debug)
    links: np.ndarray           # (L,3) skeleton link origins
    hem_ref: np.ndarray = None  # (C,3) skinned hem
    hood_ref: np.ndarray = None  # (2,3) hood at rest
    root: np.ndarray = None     # (4,4) the root's world pose; points above are in its frame
    mesh: np.ndarray = None     # (M,3,3) the skinned jacket, hood and body
    mesh_colors: np.ndarray = None  # (M,4) each triangle's shaded colour


def body_link(skeleton: 'Skeleton') -> int:
    """Return the link a picture centres on: the first from the root with two children or more.

    The pelvis of a humanoid, below any chain of virtual links carrying its world motion.

    :param skeleton: the character.
    """
    for k in range(len(skeleton.link_names)):
        if np.count_nonzero(skeleton.parent == k) >= 2:
            return k
    return 0


def in_view(frame: Frame, axes: np.ndarray, centre: int) -> Frame:
    """Return the frame in view coordinates: forward, left, up (``axes``, world) from the centre.

    The side view draws columns 0 and 2, the front view columns 1 and 2.

    :param frame: the frame, its points in the root's frame.
    :param axes: the world's forward, left and up, as the columns of a 3x3.
    :param centre: the link whose world position at the frame's moment is the origin.
    """
    root = np.eye(4) if frame.root is None else frame.root
    to_view = axes.T @ root[:3, :3]
    origin = axes.T @ (root[:3, :3] @ frame.links[centre] + root[:3, 3])

    def view(points):
        return None if points is None else points @ to_view.T + (axes.T @ root[:3, 3] - origin)

    return Frame(frame.stamp_ns, view(frame.triangles), view(frame.hood), view(frame.bones),
                 view(frame.links), view(frame.hem_ref), view(frame.hood_ref), np.eye(4),
                 view(frame.mesh), frame.mesh_colors)


def axis_label(direction: np.ndarray, meaning: str) -> str:
    """Name a view axis truthfully: the world axis it is, if it is one, and what it means.

    :param direction: the axis, (3,) in the world.
    :param meaning: what it means (``forward``, ``up``).
    """
    for k, name in enumerate('xyz'):
        for sign, mark in ((1.0, '+'), (-1.0, '-')):
            if np.allclose(direction, sign * np.eye(3)[k], atol=1e-9):
                return f'world {mark}{name} (m, {meaning})'
    return f'{meaning} (m)'


def view_axes_of(frames: Sequence[Frame], rig: 'Rig | None') -> np.ndarray:
    """Return the views' forward, left and up: the world's, as the simulation takes it.

    The rig's ``world_up`` (REP 103's +z unless the rig says otherwise): a body that lies down
    is drawn lying down (issue 47 item 1). Forward is where the body faces in the first frame
    (Rig.view_axes): the front view shows its front.

    :param frames: the frames drawn, their points in the root's frame.
    :param rig: the rig; None: x forward, z up.
    """
    if rig is None:
        return WORLD_AXES
    root = frames[0].root if frames else None
    return rig.view_axes(root_rotation=None if root is None else root[:3, :3])


def view_limits(frames: Sequence[Frame]) -> tuple[tuple[float, float], tuple[float, float]]:
    """Return (across, up) limits of the views, from the skeletons' heights in the frames.

    Measured in the world, as the frames are drawn: a URDF whose links are not Z-up, or one a
    world joint turns, is fitted all the same.

    A body lying down is as wide as it is long: the views widen to its links.

    :param frames: the frames in view coordinates (in_view).
    """
    height = np.concatenate([f.links[:, 2] for f in frames])
    size = max(float(height.max() - height.min()), 0.5)
    wide = max(float(np.abs(f.links[:, :2]).max()) for f in frames) + 0.15 * size
    half = max(0.42 * size, wide)
    return ((-half, half),
            (float(height.min()) - 0.05 * size, float(height.max()) + 0.35 * size))


def sim_frame(sim: JacketSimulation, stamp_ns: int) -> Frame:
    """Return a frame of a running simulation (its current state).

    :param sim: the simulation.
    :param stamp_ns: the frame's stamp, ns.
    """
    rig = sim.rig
    layer = sim.layer
    ref = sim.reference_points(sim.links, layer).reshape(rig.rows, rig.cols, 3)
    anchor, rot = sim.hood_anchor(sim.links)
    rest = anchor + rot @ rig.hood.rest_direction * rig.hood.length
    bones = np.stack([layer.positions, layer.tips], axis=1) if layer else np.zeros((0, 2, 3))
    mesh, colors = [], []
    for m in messages.marker_specs(sim, body=False):
        mesh.append(m.points.reshape(-1, 3, 3))
        colors.append(m.colors.reshape(-1, 3, 4).mean(axis=1))
    body, body_colors = _body_triangles(rig, sim.links)
    mesh.append(body)
    colors.append(body_colors)
    return Frame(stamp_ns, sim.x[grid_triangles(rig.rows, rig.cols)].reshape(-1, 3, 3),
                 np.array([anchor, sim.hood_p]), bones, sim.links[:, :3, 3].copy(),
                 ref[-1].copy(), np.array([anchor, rest]), sim.root.copy(),
                 np.concatenate(mesh), np.concatenate(colors))


def recorded_frames(mcap_path: str, skeleton: 'Skeleton', rig: 'Rig | None' = None,
                    choose: Callable[[np.ndarray, int], Sequence[int]] | None = None
                    ) -> tuple[list[Frame], int]:
    """Frames at recorded MarkerArrays with a mesh; the skeleton from the nearest input.

    Two passes over the markers and inputs, holding only what is drawn: the first keeps each
    marker's log time and each input's stamp, the second decodes the markers chosen and keeps
    the inputs nearest them. Every marker's bytes held at once made a long session's picture
    as large in memory as its markers; decoding them all took minutes.

    :param mcap_path: the recording.
    :param skeleton: its character.
    :param rig: its rig, for the skinned hem and hood; None: not drawn.
    :param choose: ``choose(log_times, t0)`` gives the indices of the markers to draw, from
        their log times (ns) and the first JointState's stamp; one without a mesh gives the
        next that has one. None: every marker.
    :returns: the frames and the first JointState's stamp (ns).
    """
    times = _Times(mcap_path)
    if not times.markers or not times.inputs:
        raise ValueError(_nothing_to_draw(mcap_path, times))
    log_times = np.array(times.markers, dtype=np.int64)
    t0 = times.inputs[0]
    chosen = range(len(log_times)) if choose is None else \
        [int(k) for k in choose(log_times, t0)]
    picked = _Picked(mcap_path, chosen, len(log_times), walk=choose is not None,
                     inputs=[times.nearest(t) for t in log_times[list(chosen)]])
    drawn = picked.drawn()
    picked.read_inputs({times.nearest(picked.markers[k][0]) for k in drawn})
    parser = InputParser(skeleton)
    sim = JacketSimulation(skeleton, rig, load_fabric('tweed_jacket')) if rig else None
    out = []
    for k in drawn:
        log_time, points = picked.markers[k]
        out.append(_frame(log_time, points, picked.inputs[times.nearest(log_time)], parser,
                          skeleton, sim))
    if not out:
        raise ValueError(f'{mcap_path}: nothing to draw: none of its {len(log_times)} '
                         'MarkerArray messages chosen holds the jacket\'s mesh')
    return out, t0


def _nothing_to_draw(path, times):
    """Say what a recording holds and what a picture needs: its markers and its inputs."""
    found = f'{len(times.inputs)} JointState and {len(times.markers)} MarkerArray'
    if times.inputs:        # an input-only recording: motion, import, a foreign bag
        # The rate named: a session recorded with markers_rate 0 replays with it.
        need = ('the simulation\'s markers: replay it with them first (jacket_cloth replay IN '
                '-o OUT -p markers_rate:=30.0), then draw OUT')
    elif times.markers:
        need = 'the JointState inputs the markers were made from'
    else:
        need = f'a session recorded by the node or a replay ({MARKER_ARRAY} and {JOINT_STATE})'
    return f'{path}: nothing to draw: it holds {found} messages; a picture needs {need}'


class _Times:
    """The first pass: each marker's log time and each input's stamp, in file order."""

    def __init__(self, path):
        self.path = path
        self.markers, self.inputs = [], []
        self._reader = JointStateReader()
        each_message(path, self._take, kinds=(MARKER_ARRAY, JOINT_STATE))
        # The input nearest a time, by a search in the sorted stamps: a scan of every input
        # per marker made a long session's picture quadratic in its length.
        stamps = np.array(self.inputs, dtype=np.int64)
        self._order = np.argsort(stamps, kind='stable')
        self._sorted = stamps[self._order]

    def _take(self, m):
        if m.type_name == MARKER_ARRAY:
            self.markers.append(m.log_time)
        else:
            self.inputs.append(_read_input(self._reader, m, self.path).stamp_ns)

    def nearest(self, t: int) -> int:
        """Return the ordinal (in file order) of the input whose stamp is nearest ``t``.

        :param t: a time, ns.
        :returns: the input's index among the inputs, in file order.
        """
        return int(self._order[_nearest(self._sorted, int(t))])


class _Picked:
    """The second pass: the chosen markers' points (the next with a mesh for one without)."""

    def __init__(self, path, chosen, count, walk, inputs):
        self.path = path
        self.chosen = list(chosen)
        self.markers = {}               # marker index -> (log time, points by (ns, id))
        self.inputs = {}                # input ordinal -> JointStateContent
        self._resolved = {}             # position in chosen -> the marker index drawn for it
        self._waiting = {}              # marker index -> positions in chosen waiting there
        for position, k in enumerate(self.chosen):
            self._waiting.setdefault(k, []).append(position)
        self._count, self._walk = count, walk
        self._wanted = set(inputs)
        self._reader = JointStateReader()
        self._marker = self._input = 0
        each_message(path, self._take, kinds=(MARKER_ARRAY, JOINT_STATE))

    def _take(self, m):
        if m.type_name != MARKER_ARRAY:
            if self._input in self._wanted:
                self.inputs[self._input] = _read_input(self._reader, m, self.path)
            self._input += 1
            return
        k, self._marker = self._marker, self._marker + 1
        positions = self._waiting.pop(k, None)
        if not positions:
            return
        points = _marker_points(m.data)
        if points is not None:
            self.markers[k] = (m.log_time, points)
            self._resolved.update((p, k) for p in positions)
        elif self._walk and k + 1 < self._count:
            self._waiting.setdefault(k + 1, []).extend(positions)

    def drawn(self) -> list[int]:
        """Return the marker indices drawn, in the order chosen, each once."""
        out, seen = [], set()
        for position in range(len(self.chosen)):
            k = self._resolved.get(position)
            if k is not None and k not in seen:
                out.append(k)
                seen.add(k)
        return out

    def read_inputs(self, ordinals: set[int]) -> None:
        """Read the inputs of ``ordinals`` not kept yet, in one more pass only if any.

        A marker drawn in place of a chosen one without a mesh may be nearest another input.

        :param ordinals: the inputs' indices among the inputs, in file order.
        """
        missing = ordinals - set(self.inputs)
        if not missing:
            return
        count = itertools.count()

        def take(m):
            k = next(count)
            if k in missing:
                self.inputs[k] = _read_input(self._reader, m, self.path)
        each_message(self.path, take, kinds=(JOINT_STATE,))


def _read_input(reader, m, path):
    try:
        return reader.read(m.data)
    except DECODE_ERRORS as e:
        raise ValueError(f'{path}: a {m.topic} JointState that does not decode ({e})') from None


def _marker_points(data):
    """Return the points of a recorded MarkerArray by (ns, id), a mesh's colours by (ns, 'colors').

    None without the jacket's mesh, or the cloth and hood of a recording made before it.
    """
    found = {(k.ns, k.id): k for k in read_markers(data) if k.action == Marker.ADD}
    if ('jacket', 0) not in found and (('cloth', 0) not in found or ('hood', 0) not in found):
        return None
    out = {key: k.points for key, k in found.items()}
    for ns in messages.MESH_NAMESPACES + ('body',):
        if (ns, 0) in found:
            out[ns, 'colors'] = found[ns, 0].colors
    return out


def _body_unmeshed(pts):
    """Tell whether recorded markers leave the body to be drawn: as its pieces, or not at all.

    Not at all: ``markers_body: auto`` leaves out a URDF with visuals, which RViz's robot
    model draws live; a picture draws no robot model, and the jacket must hang on a body.
    """
    return not len(pts.get(('body', 0), ()))


def _body_triangles(rig, links):
    """Return the body's mesh on the skeleton's ``links``: triangles and their colours."""
    points, colors = messages.outfit(rig).triangles('body', floats(links[:, :3, :]))
    return points.reshape(-1, 3, 3), colors.reshape(-1, 3, 4).mean(axis=1)


def _recorded_mesh(pts, rig=None):
    """Return the recorded meshes' triangles and their colours (each the mean of its corners).

    A body recorded as a triangle list (before it was sent as its pieces) is one of them. The
    live jacket is its outer faces (viewers draw both sides); with the rig its lining is put
    back, which a picture, drawing only the faces turned to it, needs to show inside.
    """
    mesh, colors = [], []
    outfit = messages.outfit(rig) if rig is not None else None
    for ns in messages.MESH_NAMESPACES + ('body',):
        if ns == 'jacket' and outfit and len(pts.get((ns, 0), ())) == outfit.marker_corners():
            tris, tri_colors = outfit.lined(pts[ns, 0], pts[ns, 'colors'])
            mesh.append(tris)
            colors.append(tri_colors)
        elif len(pts.get((ns, 0), ())):
            mesh.append(pts[ns, 0].reshape(-1, 3, 3))
            colors.append(pts[ns, 'colors'].reshape(-1, 3, 4).mean(axis=1))
    if not mesh:
        return None, None
    return np.concatenate(mesh), np.concatenate(colors)


def _frame(log_time, pts, js, parser, skeleton, sim):
    """Return the frame of a marker's points, the skeleton posed by the input ``js``."""
    bones = pts.get(('jacket_bones', 0), np.zeros((0, 3))).reshape(-1, 2, 3)
    sample = parser.parse(js.stamp_ns, js.name, js.position)
    poses = skeleton.forward(sample.q)
    mesh, colors = _recorded_mesh(pts, sim.rig if sim is not None else None)
    if sim is not None and mesh is not None and _body_unmeshed(pts):
        body, body_colors = _body_triangles(sim.rig, poses)
        mesh, colors = np.concatenate([mesh, body]), np.concatenate([colors, body_colors])
    frame = Frame(log_time, pts.get(('cloth', 0), np.zeros((0, 3))).reshape(-1, 3, 3),
                  pts.get(('hood', 0)), bones, poses[:, :3, 3], root=sample.root, mesh=mesh,
                  mesh_colors=colors)
    if sim is not None:
        sim.links = poses          # the skinned pose of this skeleton pose
        skinned = sim_frame(sim, log_time)
        frame.hem_ref, frame.hood_ref = skinned.hem_ref, skinned.hood_ref
    return frame


def _nearest(stamps: np.ndarray, t: int) -> int:
    """Return the index of the sorted ``stamps`` nearest ``t`` (the first of a tie)."""
    k = int(np.searchsorted(stamps, t))
    if k == len(stamps) or (k > 0 and t - stamps[k - 1] <= stamps[k] - t):
        k = int(np.searchsorted(stamps, stamps[k - 1]))      # a repeated stamp's first
    return k


def moments_at(times: Sequence[float] | None = None,
               moments: int = 6) -> Callable[[np.ndarray, int], list[int]]:
    """Return a ``choose`` for :func:`recorded_frames`: the markers nearest ``times``.

    :param times: the instants, s after the first JointState; None: evenly spaced ones.
    :param moments: how many evenly spaced markers, without ``times``.
    """
    def choose(log_times: np.ndarray, t0: int) -> list[int]:
        if times is None:
            return [int(k) for k in np.linspace(0, len(log_times) - 1, moments + 2)[1:-1]]
        return [int(np.argmin(np.abs(log_times - (t0 + t * 1e9)))) for t in times]
    return choose


def draw_view(ax: 'plt.Axes', frame: Frame, skeleton: 'Skeleton', axis: int,
              across: tuple[float, float], upward: tuple[float, float],
              style: str = 'jacket') -> None:
    """Draw one view of a frame (in view coordinates, see in_view) into ``ax``.

    :param ax: the matplotlib axes.
    :param frame: the frame, in view coordinates.
    :param skeleton: its character (the link parents).
    :param axis: the view coordinate drawn across: 0 side view, 1 front view.
    :param across: the limits across, metres.
    :param upward: the limits up, metres.
    :param style: ``jacket``: the shaded jacket and hood on the body; ``debug``: the method.
    """
    if style == 'jacket' and frame.mesh is not None:
        _draw_mesh(ax, frame, axis)
    else:
        _draw_method(ax, frame, skeleton, axis)
    ax.set_xlim(*across)
    ax.set_ylim(*upward)
    ax.set_aspect('equal')
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=7)


def _draw_mesh(ax, f, axis):
    """Draw the meshes back to front, faces turned away left out (the lining shows inside)."""
    flat = f.mesh[:, :, [axis, 2]]
    # The side view looks along +left (forward is drawn to the right), the front view along
    # -forward: a face is seen when its corners turn counter-clockwise on the page.
    e1, e2 = flat[:, 1] - flat[:, 0], flat[:, 2] - flat[:, 0]
    seen = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0
    toward = -f.mesh[:, :, 1].mean(axis=1) if axis == 0 else f.mesh[:, :, 0].mean(axis=1)
    order = np.argsort(toward[seen], kind='stable')
    ax.add_collection(matplotlib.collections.PolyCollection(
        flat[seen][order], facecolors=np.clip(f.mesh_colors[seen][order], 0, 1),
        edgecolors=np.clip(f.mesh_colors[seen][order] * [0.85, 0.85, 0.85, 1], 0, 1),
        linewidths=0.3))


def _draw_method(ax, f, skeleton, axis):
    """Draw the stick figure, the cloth grid, the hood pendulum, the bones, the skinned pose."""
    for i in range(1, len(f.links)):
        if skeleton.parent[i] == 0 and getattr(skeleton, 'world_root', False):
            continue                # a massless fixed root is the world: no pole to the body
        p = f.links[[skeleton.parent[i], i]]
        ax.plot(p[:, axis], p[:, 2], color='0.25', lw=2.5, solid_capstyle='round')
    ax.add_collection(matplotlib.collections.PolyCollection(
        f.triangles[:, :, [axis, 2]], facecolor=(0.45, 0.35, 0.25, 0.55),
        edgecolor=(0.25, 0.18, 0.12, 0.8), lw=0.4))
    for seg in f.bones:
        ax.plot(seg[:, axis], seg[:, 2], color=(0.15, 0.1, 0.35), lw=2)
    if f.hood is not None:
        ax.plot(f.hood[:, axis], f.hood[:, 2], color=(0.75, 0.3, 0.1), lw=3)
        ax.plot(f.hood[1, axis], f.hood[1, 2], 'o', color=(0.75, 0.3, 0.1), ms=7)
    for ref in (f.hem_ref, f.hood_ref):
        if ref is not None:
            ax.plot(ref[:, axis], ref[:, 2], '--', color=(0.2, 0.2, 0.8), lw=1.2)


def draw_filmstrip(frames: list[Frame], skeleton: 'Skeleton | Sequence[Skeleton]', png_path: str,
                   t0: int, labels: Callable[[int], str] | None = None,
                   title: str | None = None, world_axes: np.ndarray | None = None,
                   columns: Sequence[str] | None = None, style: str = 'jacket') -> None:
    """Two rows (side and front view), one column per frame, in the world (see in_view).

    :param frames: the frames, one a column.
    :param skeleton: one for every frame, or one per frame (a crowd's characters side by side).
    :param png_path: the PNG written.
    :param t0: the recording's start, ns; columns are titled by their time after it.
    :param labels: names a frame by its ns after ``t0``, after its time; None: time alone.
    :param title: the figure's title; None: what the colours show.
    :param world_axes: the world's forward, left and up (Rig.view_axes); None: x, y, z.
    :param columns: each column's title instead of its time; None: times.
    :param style: ``jacket`` (the shaded jacket on the body) or ``debug`` (see draw_view).
    """
    skeletons = list(skeleton) if isinstance(skeleton, (list, tuple)) else [skeleton] * len(
        frames)
    world_axes = WORLD_AXES if world_axes is None else world_axes
    centres = [body_link(s) for s in skeletons]
    frames = [in_view(f, world_axes, c) for f, c in zip(frames, centres)]
    across, upward = view_limits(frames)
    xlabels = (axis_label(world_axes[:, 0], 'forward'), axis_label(world_axes[:, 1], 'left'))
    ylabel = axis_label(world_axes[:, 2], 'up')
    fig, axes = plt.subplots(2, len(frames), figsize=(2.6 * len(frames), 7.2), squeeze=False)
    for col, f in enumerate(frames):
        for row, (view, axis) in enumerate(VIEWS):
            ax = axes[row][col]
            draw_view(ax, f, skeletons[col], axis, across, upward, style)
            ax.set_xlabel(xlabels[axis], fontsize=8)
            if col == 0:
                ax.set_ylabel(f'{view} view: {ylabel}', fontsize=8)
            if row == 0 and columns:
                ax.set_title(columns[col], fontsize=9)
            elif row == 0:
                name = labels(f.stamp_ns - t0) if labels else ''
                ax.set_title(f't = {(f.stamp_ns - t0) * 1e-9:.1f} s {name}', fontsize=9)
    fig.suptitle((title or DEFAULT_TITLES[style])
                 + f'\nin the world, each frame centred on {skeletons[0].link_names[centres[0]]}',
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    plt.close(fig)


def render_filmstrip(mcap_path: str, png_path: str, skeleton: 'Skeleton', moments: int = 6,
                     labels: Callable[[int], str] | None = None, title: str | None = None,
                     times: Sequence[float] | None = None,
                     rig: 'Rig | None' = None, style: str = 'jacket') -> list[int]:
    """Draw a filmstrip of a recording; return the stamps drawn.

    :param mcap_path: the recording.
    :param png_path: the PNG written.
    :param skeleton: its character.
    :param moments: how many evenly spaced instants, without ``times``.
    :param labels: names a frame by its ns from the start, after its time; None: time alone.
    :param title: the figure's title; None: what the colours show.
    :param times: the instants, s from its start; None: evenly spaced ones.
    :param rig: its rig: the skinned pose is drawn too; None: not.
    :param style: ``jacket`` or ``debug`` (see draw_view).
    """
    chosen, t0 = recorded_frames(mcap_path, skeleton, rig, moments_at(times, moments))
    if style == 'debug' and not any(len(f.triangles) for f in chosen):
        raise ValueError(f'{mcap_path}: no cloth grid to draw (the node records it with '
                         'markers_debug:=true)')
    draw_filmstrip(chosen, skeleton, png_path, t0, labels, title, view_axes_of(chosen, rig),
                   style=style)
    return [f.stamp_ns for f in chosen]
