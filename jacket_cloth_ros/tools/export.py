# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth export``: a recorded session as an animated character in glTF 2.0 binary.

The file holds one skin whose joints are the skeleton's links (the node tree of the URDF) and
then the published bones (M9 grid bones, the M8 hood bone, the M1/M2 layer bones) as children
of their parent links; the jacket-and-hood mesh and the body mesh skinned to it
(core/jacket_mesh.py, core/body_mesh.py); and the session's motion as one animation with a key
at every input the simulation took, from the same run of the simulation as ``replay``.

Nodes, from the top: ``world`` turns the simulation's world (the rig's world up) into glTF's
Y-up, with the character's first front along +Z, where glTF assets face; under it a node named
after the character carries the root's world pose (``sim.root``); under that the links, and
under each link its bones. The meshes' nodes are at the top, as glTF asks of skinned meshes.
Vertices, normals and inverse bind matrices are in glTF's axes, so each inverse bind matrix is
the inverse of its joint's global transform at rest, as Blender's importer expects.
"""

import os
import time
from dataclasses import dataclass

import numpy as np
import pygltflib as gl

from ..core.jacket_mesh import LINING, SKIN, TWEED, SkinnedMesh
from ..core.physics import skinning
from ..ros.messages import outfit
from ..core.transforms import matrix_to_quat
from .outputs import replacing
from .session import SessionInput, run_session, took_nothing

# The lining's faces lie this share of the character's height inside the outer faces: the
# outer material is double-sided, and the lining must win the depth test seen from inside.
LINING_DEPTH = 0.002
# A channel whose every key is within this of its node's rest value is left out (m, or
# quaternion components): the rest value holds it, and the file is smaller.
STILL = 1e-6

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


class ExportError(ValueError):
    """A session that cannot be exported; the message is one line."""


@dataclass
class Frames:
    """The simulation's state at each input it took: what the animation keys."""

    seconds: np.ndarray        # (F,) from the first input's stamp, strictly increasing
    root: np.ndarray           # (F,4,4) the root's world pose
    links: np.ndarray          # (F,L,4,4) the links in the simulation frame
    bones: np.ndarray          # (F,B,7) each bone in its parent link: translation, x, y, z, w
    restarts: int = 0          # stamps that went back (a reset): keyed on after the last one


@dataclass
class ExportSummary:
    """What ``export`` wrote, for the command's line and the tests."""

    path: str
    frames: int
    inputs: int                # JointState messages fed, refused ones included
    joints: int
    links: int
    bones: int
    vertices: int              # in all the meshes' primitives (the lining's its own)
    seconds: float             # wall time of the run and the writing
    restarts: int
    rig_warnings: list         # what the simulation found wrong with the rig (replay's too)


def session_frames(session: SessionInput) -> tuple[Frames, object]:
    """Run a session through the simulation as ``replay`` does; return its frames and pipeline.

    :param session: the recording's input and set-up.
    """
    roots, links, bones, stamps = [], [], [], []
    held = [None]

    def probe(pipeline, report, stamp, outputs):
        if not report.accepted or report.merged:
            return              # a refused input moved nothing, a merged one no step: no frame
        sim = pipeline.sim
        b = sim.bones()
        if not b.finite or not np.isfinite(b.poses).all():
            if held[0] is None:
                return
            poses = held[0]     # the pipeline resets on these; the last good bones hold
        else:
            poses = held[0] = b.poses.copy()
        stamps.append(int(stamp))
        roots.append(sim.root.copy())
        links.append(sim.links.copy())
        bones.append(poses)

    # Markers are output only and the export draws none: not making them saves their time.
    session.setup.values = session.setup.values.with_changes({'markers_rate': 0.0})
    pipeline = run_session(session, probe=probe)
    if not stamps:
        raise ExportError(f'{session.recording.path}: '
                          + (took_nothing(pipeline) or 'no input gave the jacket finite bones')
                          + '; nothing to animate')
    seconds, restarts = key_times(np.array(stamps, dtype=np.int64))
    return Frames(seconds, np.array(roots), np.array(links), np.array(bones), restarts), pipeline


def key_times(stamps: np.ndarray) -> tuple[np.ndarray, int]:
    """Return keys' times (s from the first stamp), strictly increasing, and how many restarted.

    A stamp at or before the one before it (the simulation reset on a jump back) is keyed one
    typical step after the last key: glTF's keys must rise, and the motion after a reset is
    the session's too.

    :param stamps: (F,) the inputs' header stamps, ns, in the order they were taken.
    """
    steps = np.diff(stamps)
    forward = steps[steps > 0]
    typical = float(np.median(forward)) if len(forward) else 1e9 / 60.0
    out = np.empty(len(stamps))
    restarts = 0
    t = 0.0
    for k in range(len(stamps)):
        if k:
            step = float(steps[k - 1])
            if step <= 0:
                restarts += 1
                step = typical
            t += step
        out[k] = t
    return out * 1e-9, restarts


def world_axes(up: np.ndarray, front: np.ndarray) -> np.ndarray:
    """Return the rotation (3,3) from the simulation's world to glTF's axes.

    The world's up becomes +Y and ``front``, made square to up, +Z.

    :param up: the world's up, world frame.
    :param front: the character's front at the first frame, world frame.
    """
    up = np.asarray(up, float) / np.linalg.norm(up)
    f = np.asarray(front, float) - (np.asarray(front, float) @ up) * up
    if np.linalg.norm(f) < 1e-6:            # facing straight up or down: any front will do
        f = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    f /= np.linalg.norm(f)
    return np.array([np.cross(up, f), up, f])


def _affine(m: np.ndarray) -> np.ndarray:
    """Return (...,3,4) transforms as (...,4,4)."""
    out = np.zeros(m.shape[:-2] + (4, 4))
    out[..., :3, :] = m[..., :3, :]
    out[..., 3, 3] = 1.0
    return out


def _trs(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the translations (...,3) and unit quaternions x, y, z, w (...,4) of rigid m."""
    return m[..., :3, 3].copy(), matrix_to_quat(m[..., :3, :3])


def _continuous(q: np.ndarray) -> np.ndarray:
    """Flip quaternions (F,N,4) so each key is on the side of the one before.

    glTF's LINEAR rotation keys are slerped between, so a sign flip would spin the long way.
    """
    q = q.copy()
    for k in range(1, len(q)):
        flip = np.einsum('ni,ni->n', q[k], q[k - 1]) < 0
        q[k, flip] *= -1
    return q


def _within_float32(values: np.ndarray, what: str) -> None:
    """Refuse values glTF's 32-bit floats cannot hold: cast, they were infinities in the file."""
    largest = float(np.abs(values).max(initial=0.0))
    if largest > float(np.finfo(np.float32).max):       # a Python float: no cast to warn
        raise ValueError(f'{what} of {largest:.3g} is beyond glTF\'s 32-bit floats')


def key_times_32(seconds: np.ndarray) -> np.ndarray:
    """Return the keys' times as glTF holds them (32-bit floats), refused unless they rise.

    Rounded to 32 bits, neighbouring keys of a long session (or after a wide gap in its
    stamps) become one time, which glTF forbids: said in one line, not written.

    :param seconds: (F,) the keys' times, s, strictly increasing (key_times).
    """
    keys = seconds.astype(np.float32)
    tied = np.flatnonzero(np.diff(keys) <= 0)
    if len(tied):
        k = int(tied[0])
        raise ValueError(f'the keys at {seconds[k]:.6f} s and {seconds[k + 1]:.6f} s are one '
                         'time in glTF\'s 32-bit floats: the session runs too long at its '
                         'rate, or a gap in its stamps is too wide')
    return keys


class _Blob:
    """The binary chunk: arrays appended 4-byte aligned, each with its buffer view."""

    def __init__(self, gltf: gl.GLTF2):
        self.gltf, self.parts, self.size = gltf, [], 0

    def view(self, data: np.ndarray, target: int | None = None) -> int:
        raw = np.ascontiguousarray(data).tobytes()
        pad = -self.size % 4
        self.parts.append(b'\0' * pad)
        self.size += pad
        self.gltf.bufferViews.append(gl.BufferView(buffer=0, byteOffset=self.size,
                                                   byteLength=len(raw), target=target))
        self.parts.append(raw)
        self.size += len(raw)
        return len(self.gltf.bufferViews) - 1

    def accessor(self, data: np.ndarray, kind: str, component: int,
                 target: int | None = None, bounds: bool = False) -> int:
        dtype = {FLOAT: np.float32, UBYTE: np.uint8, USHORT: np.uint16, UINT: np.uint32}
        with np.errstate(over='ignore'):        # said below, in a line of its own
            data = np.ascontiguousarray(data, dtype=dtype[component])
        if component == FLOAT and not np.isfinite(data).all():
            # The simulation's values are finite: an infinity is a cast that overflowed.
            raise ValueError('a value beyond glTF\'s 32-bit floats')
        count = len(data)
        flat = data.reshape(count, -1)
        extra = {}
        if bounds:
            extra = dict(min=flat.min(axis=0).tolist(), max=flat.max(axis=0).tolist())
            if component != FLOAT:
                extra = {k: [int(x) for x in v] for k, v in extra.items()}
            else:
                extra = {k: [float(x) for x in v] for k, v in extra.items()}
        self.gltf.accessors.append(gl.Accessor(bufferView=self.view(data, target),
                                               componentType=component, count=count, type=kind,
                                               **extra))
        return len(self.gltf.accessors) - 1

    def done(self) -> None:
        blob = b''.join(self.parts)
        self.gltf.buffers = [gl.Buffer(byteLength=len(blob))]
        self.gltf.set_binary_blob(blob)


def _normals(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """Return unit vertex normals (V,3), as the markers shade them; +y where a vertex has no area.

    glTF asks for a unit NORMAL on every vertex, so the compiled normals' zeros are turned up.
    """
    out = np.empty(points.shape)
    skinning.vertex_normals(points, np.ascontiguousarray(triangles, dtype=np.int64), out)
    out[~out.any(axis=1)] = [0.0, 1.0, 0.0]
    return out


def _primitive(blob: _Blob, mesh: SkinnedMesh, faces: np.ndarray, axes: np.ndarray,
               material: int, inset: float = 0.0) -> gl.Primitive:
    """Return a primitive of some of a mesh's faces, with its own vertices, in glTF's axes.

    ``inset`` moves each vertex that far along its normal (the lining, into the jacket).
    """
    tris = mesh.triangles[faces]
    used, index = np.unique(tris, return_inverse=True)
    index = index.reshape(tris.shape)
    points = mesh.rest[used] @ axes.T
    normals = _normals(points, index)
    points = points + inset * normals
    weights = mesh.weights[used].astype(np.float32)
    weights /= weights.sum(axis=1, keepdims=True)
    joints = mesh.joints[used]
    attributes = gl.Attributes(
        POSITION=blob.accessor(points, gl.VEC3, FLOAT, ARRAY_BUFFER, bounds=True),
        NORMAL=blob.accessor(normals, gl.VEC3, FLOAT, ARRAY_BUFFER),
        JOINTS_0=blob.accessor(joints, gl.VEC4, UBYTE if joints.max() < 256 else USHORT,
                               ARRAY_BUFFER),
        WEIGHTS_0=blob.accessor(weights, gl.VEC4, FLOAT, ARRAY_BUFFER))
    indices = blob.accessor(index.reshape(-1), gl.SCALAR, UINT, ELEMENT_ARRAY_BUFFER)
    return gl.Primitive(attributes=attributes, indices=indices, material=material)


def _material(name: str, color: tuple, double_sided: bool) -> gl.Material:
    # glTF's base colour is linear; the colours are picked on screens (sRGB), as the markers
    # and pictures show them: taken as they are, Blender drew the tweed beige.
    rgb = [float(c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4)
           for c in color[:3]]
    return gl.Material(name=name, doubleSided=double_sided,
                       pbrMetallicRoughness=gl.PbrMetallicRoughness(
                           baseColorFactor=rgb + [float(color[3])], metallicFactor=0.0,
                           roughnessFactor=0.9))


def build_gltf(session: SessionInput, frames: Frames, bone_names: list, bone_parents: list,
               world_up: np.ndarray) -> gl.GLTF2:
    """Return the glTF document of a session's frames: skin, meshes, animation.

    :param session: the recording's input and set-up (skeleton, rig, the character's name).
    :param frames: the simulation's state at each input (session_frames).
    :param bone_names: the published bones (simulation.BoneSet.names).
    :param bone_parents: each one's parent link's name.
    :param world_up: the world's up the simulation used (after its first input), world frame.
    """
    skeleton, rig = session.setup.skeleton, session.setup.rig
    n_links, n_bones = len(skeleton.link_names), len(bone_names)
    jacket, body = outfit(rig).jacket, outfit(rig).body       # as the markers draw them
    first_front = frames.root[0, :3, :3] @ frames.links[0, 0, :3, :3] @ rig.world_axes[:, 0]
    axes = world_axes(world_up, first_front)
    gltf = gl.GLTF2(asset=gl.Asset(version='2.0', generator='jacket_cloth_ros export'))
    gltf.scene = 0
    blob = _Blob(gltf)

    # Nodes: 0 world axes, 1 the character's root pose, then links, bones, the two meshes.
    rest = _affine(np.linalg.inv(_affine(jacket.inverse_rest)))       # joints at rest, sim
    parent_of = np.concatenate([np.asarray(skeleton.parent, dtype=np.int64),
                                [skeleton.link_names.index(p) for p in bone_parents]])
    link0, bone0 = 2, 2 + n_links
    local_rest = rest.copy()
    local_rest[1:] = np.linalg.inv(rest[parent_of[1:]]) @ rest[1:]
    t_rest, q_rest = _trs(local_rest)
    # The root's first position rides on the world node, as JSON's 64-bit numbers; the
    # root's keys (32-bit floats) are its moves from there, which keeps them exact far from
    # the world's origin.
    world = gl.Node(name='world', rotation=matrix_to_quat(axes).tolist(),
                    translation=(axes @ frames.root[0, :3, 3]).tolist(), children=[1])
    root = gl.Node(name=skeleton.name or 'character', children=[link0])
    nodes = [world, root]
    children = [[] for _ in range(n_links)]
    for j in range(1, n_links + n_bones):
        children[int(parent_of[j])].append(j)
    names = list(skeleton.link_names) + list(bone_names)
    for j in range(n_links + n_bones):
        kids = [link0 + c for c in children[j]] if j < n_links else []
        nodes.append(gl.Node(name=names[j], translation=t_rest[j].tolist(),
                             rotation=q_rest[j].tolist(), children=kids or None))
    jacket_node, body_node = len(nodes), len(nodes) + 1
    nodes += [gl.Node(name='jacket', mesh=0, skin=0), gl.Node(name='body', mesh=1, skin=0)]
    gltf.nodes = nodes
    title = os.path.basename(os.path.normpath(session.recording.path))
    gltf.scenes = [gl.Scene(name=title, nodes=[0, jacket_node, body_node])]

    # The skin: each inverse bind matrix the inverse of its joint at rest in glTF's axes.
    to_gltf = np.eye(4)
    to_gltf[:3, :3] = axes
    inverse_bind = np.linalg.inv(to_gltf @ rest)
    ibm = blob.accessor(np.transpose(inverse_bind, (0, 2, 1)).reshape(-1, 16), gl.MAT4, FLOAT)
    gltf.skins = [gl.Skin(name='skeleton and jacket layer', inverseBindMatrices=ibm,
                          joints=list(range(link0, bone0 + n_bones)), skeleton=link0)]

    # Materials and meshes: the jacket's outer faces, its lining just inside, the body.
    gltf.materials = [_material('tweed', TWEED, True), _material('lining', LINING, False),
                      _material('body', SKIN, False)]
    front, back = np.flatnonzero(~jacket.back), np.flatnonzero(jacket.back)
    prims = [_primitive(blob, jacket, front, axes, 0)]
    if len(back):
        prims.append(_primitive(blob, jacket, back, axes, 1,
                                inset=LINING_DEPTH * max(rig.height_m, 0.3)))
    body_prim = _primitive(blob, body, np.arange(len(body.triangles)), axes, 2)
    gltf.meshes = [gl.Mesh(name='jacket and hood', primitives=prims),
                   gl.Mesh(name='body', primitives=[body_prim])]

    _animation(gltf, blob, frames, parent_of, n_links, t_rest, q_rest)
    blob.done()
    return gltf


def _animation(gltf, blob, frames, parent_of, n_links, t_rest, q_rest):
    """Add the session's animation: the root's world pose, every link and bone at each key."""
    link0 = 2
    _within_float32(frames.root[:, :3, 3], 'the root\'s world position')
    times = blob.accessor(key_times_32(frames.seconds), gl.SCALAR, FLOAT, bounds=True)
    # Each link in its parent link (the root link in the character's root).
    local = frames.links.copy()
    local[:, 1:] = np.linalg.inv(frames.links[:, parent_of[1:n_links]]) @ frames.links[:, 1:]
    t_links, q_links = _trs(local)
    t_root, q_root = _trs(frames.root)
    t_root = t_root - t_root[0]             # from where the world node puts it (build_gltf)
    t_all = np.concatenate([t_links, frames.bones[:, :, :3]], axis=1)
    q_all = np.concatenate([q_links, frames.bones[:, :, 3:]], axis=1)
    q_all = q_all / np.linalg.norm(q_all, axis=2, keepdims=True)
    samplers, channels = [], []

    def key(node, path, values):
        samplers.append(gl.AnimationSampler(
            input=times, output=blob.accessor(values, gl.VEC3 if path != 'rotation' else gl.VEC4,
                                              FLOAT),
            interpolation='LINEAR'))
        channels.append(gl.AnimationChannel(
            sampler=len(samplers) - 1, target=gl.AnimationChannelTarget(node=node, path=path)))

    key(1, 'translation', t_root)
    key(1, 'rotation', _continuous(q_root[:, None])[:, 0])
    q_all = _continuous(q_all)
    for j in range(t_all.shape[1]):
        if np.abs(t_all[:, j] - t_rest[j]).max() > STILL:
            key(link0 + j, 'translation', t_all[:, j])
        still = min(np.abs(q_all[:, j] - q_rest[j]).max(), np.abs(q_all[:, j] + q_rest[j]).max())
        if still > STILL:
            key(link0 + j, 'rotation', q_all[:, j])
    gltf.animations = [gl.Animation(name='session', samplers=samplers, channels=channels)]


def export(session: SessionInput, out_path: str, force: bool = False) -> ExportSummary:
    """Write ``session`` as glTF 2.0 binary to ``out_path``; return what was written.

    :param session: the recording's input and set-up.
    :param out_path: the .glb file, replaced only once it is whole.
    :param force: whether a file at ``out_path`` is replaced.
    """
    started = time.perf_counter()
    frames, pipeline = session_frames(session)
    sim = pipeline.sim
    bone_set = sim.bone_set
    gltf = build_gltf(session, frames, list(bone_set.names), list(bone_set.parents),
                      np.asarray(sim.model.cloth.up, float))
    with replacing(out_path, force=force) as tmp:
        gltf.save_binary(tmp)
    vertices = sum(gltf.accessors[p.attributes.POSITION].count
                   for m in gltf.meshes for p in m.primitives)
    return ExportSummary(out_path, len(frames.seconds), pipeline.inputs,
                         len(gltf.skins[0].joints), len(sim.skeleton.link_names),
                         len(bone_set.names), vertices, time.perf_counter() - started,
                         frames.restarts, list(sim.faults.rig))
