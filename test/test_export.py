# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth export``: every .glb written here passes the Khronos validator and is read back
by an independent reader (pygltflib), its skinning computed here from the file alone."""

import json
import os
import subprocess
import sys

import numpy as np
import pygltflib
import pytest

from jacket_cloth_ros.core.config import shipped
from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
from jacket_cloth_ros.core.jacket_mesh import jacket_mesh, posed_joints, skinned
from jacket_cloth_ros.core.skeleton import Skeleton
from jacket_cloth_ros.recording.writer import SessionRecorder, qos_profile_yaml
from jacket_cloth_ros.ros.cdr import joint_state
from jacket_cloth_ros.tools.cli import main
from jacket_cloth_ros.tools.export import key_times, key_times_32
from jacket_cloth_ros.tools.session import load_session, run_session

HERE = os.path.dirname(os.path.abspath(__file__))
# make test installs the validator into the venv (Makefile: gltf-validator).
NODE_MODULES = os.path.join(sys.prefix, 'node', 'node_modules')
LIFT = 2.0


def validate(path):
    """Return the Khronos glTF validator's report of a file (counts and first messages)."""
    assert os.path.isdir(os.path.join(NODE_MODULES, 'gltf-validator')), \
        f'the glTF validator is not in {NODE_MODULES}: run make test (its gltf-validator step)'
    done = subprocess.run(['node', os.path.join(HERE, 'gltf_validate.js'), str(path)],
                          env=dict(os.environ, NODE_PATH=NODE_MODULES), capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


class Glb:
    """A .glb read with pygltflib, its accessors as numpy arrays, posed here from its nodes."""

    def __init__(self, path):
        self.gltf = pygltflib.GLTF2().load_binary(str(path))
        self.blob = self.gltf.binary_blob()

    def data(self, index):
        a = self.gltf.accessors[index]
        view = self.gltf.bufferViews[a.bufferView]
        dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16, 5125: np.uint32}
        width = {'SCALAR': 1, 'VEC3': 3, 'VEC4': 4, 'MAT4': 16}[a.type]
        start = (view.byteOffset or 0) + (a.byteOffset or 0)
        out = np.frombuffer(self.blob, dtype[a.componentType], a.count * width, start)
        return out.reshape(a.count, width) if width > 1 else out

    def node_globals(self, key):
        """Every node's global transform (N,4,4) at animation key ``key``."""
        nodes = self.gltf.nodes
        trs = [[np.array(n.translation or [0, 0, 0], float),
                np.array(n.rotation or [0, 0, 0, 1], float)] for n in nodes]
        anim = self.gltf.animations[0]
        for ch in anim.channels:
            values = self.data(anim.samplers[ch.sampler].output)
            trs[ch.target.node][0 if ch.target.path == 'translation' else 1] = values[key]
        local = np.array([_matrix(t, q) for t, q in trs])
        out = np.empty_like(local)
        parent = {c: k for k, n in enumerate(nodes) for c in (n.children or [])}

        def place(k):
            if k in parent:
                return place(parent[k]) @ local[k]
            return local[k]
        for k in range(len(nodes)):
            out[k] = place(k)
        return out

    def skinned(self, primitive, key):
        """A primitive's vertices (V,3) skinned at key ``key``, glTF's linear blend skinning."""
        skin = self.gltf.skins[0]
        g = self.node_globals(key)
        ibm = self.data(skin.inverseBindMatrices).reshape(-1, 4, 4).transpose(0, 2, 1)
        joints = g[skin.joints] @ ibm
        a = primitive.attributes
        p, j, w = self.data(a.POSITION), self.data(a.JOINTS_0), self.data(a.WEIGHTS_0)
        p4 = np.concatenate([p, np.ones((len(p), 1))], axis=1)
        out = np.zeros((len(p), 4))
        for k in range(4):
            out += w[:, k, None] * np.einsum('vij,vj->vi', joints[j[:, k]], p4)
        return out[:, :3]


def _matrix(t, q):
    x, y, z, w = q / np.linalg.norm(q)
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = t
    return m


@pytest.fixture(scope='module')
def walk(tmp_path_factory):
    """2 s of the walk clip at 30 Hz (61 inputs), input only, as the motion tool writes it."""
    path = tmp_path_factory.mktemp('walk') / 'walk.mcap'
    assert main(['motion', '--clip', 'walk', '--rate', '30', '--duration', '2', '-o',
                 str(path)]) == 0
    return path


def _still_session(path, urdf, inputs=5, lift=LIFT, x=0.0, creep=0.0):
    """A JointState recording of a character at its zero pose, its root ``lift`` m up (clear of
    the floor, which would push the cloth), without a set-up; at ``x`` m along the world's x,
    moving on by ``creep`` m an input."""
    with open(urdf, encoding='utf-8') as f:
        names = list(Skeleton(f.read()).joint_names)
    world = [f'world_joint/{v}' for v in WORLD_VARIABLES]
    rec = SessionRecorder(str(path), exclusive=False)
    rec.add_topic('/joint_states', 'sensor_msgs/msg/JointState', qos_profile_yaml())
    for k in range(inputs):
        stamp = 7_000_000_000 + k * 20_000_000
        rec.write('/joint_states', joint_state(stamp, names + world, [0.0] * len(names) + [
            x + k * creep, 0.0, lift, 0.0, 0.0, 0.0, 1.0]), stamp)
    rec.close()


def test_export_validates_reads_back_and_keys_every_input(walk, tmp_path, capsys):
    out = tmp_path / 'walk.glb'
    assert main(['export', str(walk), '-o', str(out)]) == 0
    assert 'walk.glb: 61 frames of 61 JointState' in capsys.readouterr().out
    report = validate(out)
    assert report['errors'] == 0 and report['warnings'] == 0, report['messages']
    glb = Glb(out)
    session = load_session(str(walk))
    sim = run_session(session).sim
    bones = sim.bone_set
    skin = glb.gltf.skins[0]
    assert len(skin.joints) == len(sim.skeleton.link_names) + len(bones.names)
    names = [glb.gltf.nodes[j].name for j in skin.joints]
    assert names == list(sim.skeleton.link_names) + list(bones.names)
    # Bones hang from their parent links; links from theirs.
    parent = {c: k for k, n in enumerate(glb.gltf.nodes) for c in (n.children or [])}
    by_name = {n.name: k for k, n in enumerate(glb.gltf.nodes)}
    for name, link in zip(bones.names, bones.parents):
        assert parent[by_name[name]] == by_name[link]
    anim = glb.gltf.animations[0]
    times = {s.input for s in anim.samplers}
    assert len(times) == 1
    keys = glb.data(times.pop())
    assert len(keys) == 61 and keys[0] == 0.0 and np.all(np.diff(keys) > 0)
    assert keys[-1] == pytest.approx(2.0, abs=1e-4)
    assert all(glb.gltf.accessors[s.output].count == 61 for s in anim.samplers)
    # The world pose rides on the character's root node, under the world's axes.
    root = by_name[sim.skeleton.name]
    assert {ch.target.path for ch in anim.channels if ch.target.node == root} == {
        'translation', 'rotation'}


def test_the_last_key_skins_the_jacket_where_the_simulation_left_it(walk, tmp_path):
    out = tmp_path / 'walk.glb'
    assert main(['export', str(walk), '-o', str(out)]) == 0
    glb = Glb(out)
    session = load_session(str(walk))
    sim = run_session(session).sim
    bones = sim.bone_set
    mesh = jacket_mesh(sim.skeleton, sim.rig, bones.names, bones.parents, bones.grid)
    parents = np.array([sim.skeleton.link_names.index(p) for p in bones.parents])
    ours = skinned(mesh, posed_joints(sim.links, parents, sim.bones().poses))
    ours = ours @ sim.root[:3, :3].T + sim.root[:3, 3]           # into the world
    axes = glb.node_globals(0)[0][:3, :3]                        # the world into glTF's axes
    front = glb.gltf.meshes[0].primitives[0]
    theirs = glb.skinned(front, 60)
    # The front primitive's vertices are the mesh's front faces' vertices, in order.
    used = np.unique(mesh.triangles[~mesh.back])
    assert np.abs(theirs - ours[used] @ axes.T).max() < 1e-4


def test_a_still_session_skins_to_the_rest_mesh_at_its_first_key(tmp_path):
    urdf, rig = shipped('examples/mannequin.urdf'), shipped('examples/mannequin_rig.yaml')
    still = tmp_path / 'still.mcap'
    _still_session(still, urdf)
    out = tmp_path / 'still.glb'
    assert main(['export', str(still), '-o', str(out), '--urdf', urdf, '--rig', rig]) == 0
    report = validate(out)
    assert report['errors'] == 0, report['messages']
    glb = Glb(out)
    session = load_session(str(still), urdf=urdf, rig=rig)
    sim = run_session(session).sim
    bones = sim.bone_set
    mesh = jacket_mesh(sim.skeleton, sim.rig, bones.names, bones.parents, bones.grid)
    axes = glb.node_globals(0)[0][:3, :3]
    front = glb.gltf.meshes[0].primitives[0]
    used = np.unique(mesh.triangles[~mesh.back])
    rest = glb.data(front.attributes.POSITION)
    assert np.abs(rest - mesh.rest[used] @ axes.T).max() < 1e-5
    # Skinned at the first key: the rest mesh, lifted with the root in the world.
    lifted = axes @ [0.0, 0.0, LIFT]
    assert np.abs(glb.skinned(front, 0) - (rest + lifted)).max() < 1e-4
    body = glb.gltf.meshes[1].primitives[0]
    assert np.abs(glb.skinned(body, 0) - (glb.data(body.attributes.POSITION) + lifted)
                  ).max() < 1e-4
    assert len(glb.data(glb.gltf.animations[0].samplers[0].input)) == 5


def test_the_root_is_keyed_to_the_millimetre_far_from_the_origin(tmp_path):
    # 500 km away, a root creeping 1 mm an input was keyed as 32-bit floats, in steps of
    # 3 cm (still for 30 inputs, then a jump). Its first position rides on the world node now, as
    # JSON's 64-bit numbers, and the keys hold its moves from there.
    urdf = shipped('character.urdf')
    far, out = tmp_path / 'far.mcap', tmp_path / 'far.glb'
    _still_session(far, urdf, inputs=40, x=5e5, creep=0.001)
    assert main(['export', str(far), '-o', str(out)]) == 0
    glb = Glb(out)
    axes = glb.node_globals(0)[0][:3, :3]
    roots = []
    run_session(load_session(str(far)), probe=lambda p, r, stamp, o: roots.append(
        p.sim.root[:3, 3].copy()))
    assert len(roots) == 40
    for key, root in enumerate(roots):
        placed = glb.node_globals(key)[1][:3, 3]        # the character's root node
        assert np.abs(placed - axes @ root).max() < 1e-6, key


def _one_line_error(capsys, argv):
    assert main(argv) != 0
    err = capsys.readouterr().err.strip()
    assert '\n' not in err and 'Traceback' not in err
    return err


def test_bad_input_is_one_line_and_a_failure(walk, tmp_path, capsys):
    out = str(tmp_path / 'x.glb')
    text = tmp_path / 'notes.mcap'
    text.write_text('not a recording')
    assert 'not an MCAP file' in _one_line_error(capsys, ['export', str(text), '-o', out])
    # A foreign skeleton's recording without its URDF: the shipped character has none of its
    # joints.
    still = tmp_path / 'mannequin.mcap'
    _still_session(still, shipped('examples/mannequin.urdf'))
    assert '--urdf' in _one_line_error(capsys, ['export', str(still), '-o', out])
    missing = str(tmp_path / 'no.urdf')
    assert 'no.urdf' in _one_line_error(capsys, ['export', str(still), '-o', out, '--urdf',
                                                 missing])
    assert not os.path.exists(out)
    assert main(['export', str(walk), '-o', out]) == 0
    assert 'exists' in _one_line_error(capsys, ['export', str(walk), '-o', out])
    # Binary glTF under any name (an .mcap out of a replay's habit, a .gltf, which is JSON)
    # was written as asked (a probe).
    for name in (walk.name, 'x.gltf', 'session', 'x.png'):
        target = tmp_path / name
        assert _one_line_error(capsys, ['export', str(walk), '-o', str(target), '--force']) \
            .endswith(f'{target}: export writes binary glTF; end the name in .glb')
    assert sorted(os.listdir(tmp_path)) == ['mannequin.mcap', 'notes.mcap', 'x.glb']


def test_keys_rise_where_the_stamps_go_back():
    # A jump back resets the simulation; glTF's key times must still rise.
    ms = 1_000_000
    seconds, restarts = key_times(np.array([100, 110, 120, 40, 50, 60]) * ms)
    assert restarts == 1
    assert np.allclose(seconds, [0.0, 0.01, 0.02, 0.03, 0.04, 0.05])


def test_keys_that_32_bit_floats_make_one_time_are_refused():
    # A wide gap in the stamps (or a session of days at its rate): rounded to glTF's 32-bit
    # floats, neighbouring keys became one time, which glTF forbids, and the file was written.
    seconds = np.array([0.0, 1.0, 1e6, 1e6 + 1 / 60])
    with pytest.raises(ValueError, match=r'the keys at 1000000\.000000 s and 1000000\.016667 '
                                         r's are one time'):
        key_times_32(seconds)
    assert key_times_32(seconds[:3]).dtype == np.float32


def test_a_world_position_beyond_32_bit_floats_is_one_line_and_no_file(tmp_path, capsys):
    # Written as it was, the root's translation keys were infinities in a file said written.
    session, out = tmp_path / 'far.mcap', tmp_path / 'far.glb'
    _still_session(session, shipped('character.urdf'), lift=1e300)
    err = _one_line_error(capsys, ['export', str(session), '-o', str(out)])
    assert err == ('jacket_cloth export: the root\'s world position of 1e+300 is beyond '
                   'glTF\'s 32-bit floats')
    assert not out.exists()
