# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth_lab stress``: the scenes where cloth methods fail, run for every method.

Each scene feeds the shipped character's JointState to the simulation core (the same
``JacketSimulation.process`` the node calls), then one and a half seconds of standing still,
and is judged on what a user would see:

- non-finite: a NaN or inf in the cloth (the simulation resets itself on one; counted here);
- exploded: a vertex more than ``EXPLODED_M`` from where the skinned pose puts it;
- tunnelled: a vertex left more than ``TUNNEL_M`` inside a collider at the end of an input;
- knotted/flipped: more than ``FLIPPED_SHARE`` of the mesh triangles facing the other way than
  on the skinned pose, after the calm tail;
- stretched: a vertical edge more than ``VERTICAL_BOUND`` over its rest length at the end of
  any input (what a viewer sees as a rubber hem for a few frames);
- did not recover: the hem still more than ``RECOVER_M`` (mean) from the skinned hem after the
  calm tail;
- did not settle (a scene that ends on the floor): the hem still moving, a path of more than
  ``SETTLE_M`` (mean over its vertices) in the last ``SETTLE_S`` of the calm tail. A hem
  standing up still swings down from the scene's motion there; on the floor the converged
  cloth lies still well within it, and a cloth that moves on keeps moving (a cycle).

A scene that ends on the floor is judged against the converged cloth of the same scene
(``REFERENCE_SWEEPS`` sweeps in ``REFERENCE_SUBSTEPS`` substeps) instead of the skinned pose,
which puts the hem inside the floor: flipped triangles against its triangles, the hem's
distance from its hem.
"""

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.geometry import grid_triangles
from jacket_cloth_ros.core.rig import Rig, load_rig
from jacket_cloth_ros.core.physics.cloth import StretchLimit
from jacket_cloth_ros.core.measures import edge_strain
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.core.skeleton import Skeleton, load_shipped_character
from jacket_cloth_ros.motion.clips import joint_state_content, smoothstep
from .accuracy import deepest_inside

EXPLODED_M = 1.0
FLOOR = 'floor: '                  # the name of every scene where the body meets the floor
TUNNEL_M = 0.02
FLIPPED_SHARE = 0.10
VERTICAL_BOUND = 0.10
RECOVER_M = 0.15
SETTLE_M, SETTLE_S = 0.005, 0.5
REFERENCE_SWEEPS, REFERENCE_SUBSTEPS = 64, 4
RATE = 60.0
CALM_S = 1.5
METHODS = StretchLimit.names()           # how the vertical stretch is removed (none first)
# The same with XPBD as the solver ('xpbd+<stretch_limit>'); the names above are Gauss-Seidel's.
XPBD_METHODS = tuple(f'xpbd+{m}' for m in METHODS)


@dataclass
class Scene:
    name: str
    inputs: list                         # (stamp_ns, names, positions)
    params: dict = field(default_factory=dict)
    fabric: dict = field(default_factory=dict)
    ends_on_floor: bool = False          # judged by settling, not by the skinned pose


def _clip(skeleton, clip, t0, t1, start_s=10.0, every=1, edit=None):
    out = []
    for k in range(int(round(t0 * RATE)), int(round(t1 * RATE)), every):
        t = k / RATE
        names, pos = joint_state_content(skeleton.joint_names, clip, t)
        if edit:
            pos = edit(names, list(pos), t)
        out.append((int(round((start_s + t) * 1e9)), names, pos))
    return out


def _calm(skeleton, after_s, pose_from):
    """Standing still after a scene, in the last scene pose's place in the world."""
    _, last = pose_from
    idle_names, idle = joint_state_content(skeleton.joint_names, 'idle', 0.0)
    joints = len(skeleton.joint_names)
    pos = list(idle[:joints]) + list(last[joints:])
    return [(int(round((after_s + k / RATE) * 1e9)), idle_names, pos)
            for k in range(1, int(CALM_S * RATE) + 1)]


def _with_calm(skeleton, inputs):
    stamp, names, pos = inputs[-1]
    return inputs + _calm(skeleton, stamp * 1e-9, (names, pos))


def scenes(skeleton: Skeleton, loop_s: float = 60.0) -> list[Scene]:
    """Return the failure scenes, as JointState content for the shipped character.

    :param skeleton: the shipped character.
    :param loop_s: how long the looped walk runs, seconds.
    """
    joints = len(skeleton.joint_names)

    def turned(names, pos, t):          # 180 degrees about z in one frame, at 1 s
        if t >= 1.0:
            pos[joints + 5], pos[joints + 6] = 1.0, 0.0
        return pos

    def kicked(names, pos, t):          # the left thigh through the cloth at 30 rad/s
        phase = (t * 30.0) % (2 * 1.4)
        pos[names.index('l_hip_pitch')] = -(phase if phase < 1.4 else 2 * 1.4 - phase)
        return pos

    def garbage(names, pos, t):          # every 10th input NaN, every 10th+5th all zeros
        k = int(round(t * RATE))
        if k % 10 == 0:
            return [math.nan] * len(pos)
        if k % 10 == 5:
            return [0.0] * len(pos)
        return pos

    hitch = [i for i in _clip(skeleton, 'walk', 0.0, 3.0) if not 10.0 + 1.5 <= i[0] * 1e-9 < 12.0]
    return [
        Scene('teleport 10 m', _with_calm(skeleton, _clip(skeleton, 'teleport', 0.0, 3.0))),
        Scene('180 deg turn in one frame',
              _with_calm(skeleton, _clip(skeleton, 'idle', 0.0, 2.0, edit=turned)),
              params={'teleport_angle_deg': 180.0}),
        Scene('0.5 s frame hitch', _with_calm(skeleton, hitch)),
        Scene('thigh through the cloth at 30 rad/s',
              _with_calm(skeleton, _clip(skeleton, 'idle', 0.0, 2.0, edit=kicked))),
        Scene('step 10x too large (12 Hz)', _with_calm(skeleton, _clip(skeleton, 'run', 0.0, 3.0)),
              params={'sim_rate': 12.0}),
        Scene('full stiffness, 100 iterations',
              _with_calm(skeleton, _clip(skeleton, 'run', 0.0, 2.0)),
              fabric={'stretch_stiffness': 1.0, 'shear_bend_stiffness': 1.0, 'iterations': 100}),
        Scene('NaN and all-zero input',
              _with_calm(skeleton, _clip(skeleton, 'walk', 0.0, 2.0, edit=garbage))),
        Scene(f'walk looped for {loop_s:.0f} s',     # the gait repeats; the walker goes on
              _with_calm(skeleton, _clip(skeleton, 'walk', 0.0, loop_s))),
        *floor_scenes(skeleton),
    ]


# The body on the floor (issue 47 item 2), each scene from standing, world up +z and the rig's
# floor plane at z = 0. A key pose: joint values, the root's position (m) and its roll and
# pitch (rad, about world x then y; pitch > 0 leans forward). The root is the pelvis; lying
# down, it sits one centimetre further from the floor than the shipped pelvis and torso
# colliders reach (0.13-0.135 m front and back, 0.175-0.18 m to the sides): the body on the
# floor, the cloth between them.
# No joint origin (ankle, wrist) nearer the floor than this. The still key poses' lowest, all
# fours' wrists, are a little above it; the crawl's strides (a foot at 1.25 cm) and the roll
# on its side (onto the lower arm) are lifted a few centimetres.
JOINT_CLEARANCE_M = 0.035
_ARMS_DOWN = {'l_elbow': -0.1, 'r_elbow': -0.1}
_STAND = (_ARMS_DOWN, (0.0, 0.0, 0.96), (0.0, 0.0))
# Both knees on the floor (shin capsules 0.06), thighs upright, shins behind.
_KNEEL = ({**_ARMS_DOWN, 'l_knee': 1.55, 'r_knee': 1.55, 'l_ankle': 0.5, 'r_ankle': 0.5},
          (0.0, 0.0, 0.56), (0.0, 0.0))
# Sitting on the floor, legs ahead, hands beside the hips.
_SIT = ({'l_hip_pitch': -1.5, 'r_hip_pitch': -1.5, 'l_shoulder_pitch': 0.4,
         'r_shoulder_pitch': 0.4, 'l_elbow': -0.1, 'r_elbow': -0.1, 'spine_pitch': 0.1},
        (0.1, 0.0, 0.18), (0.0, 0.0))
_SQUAT = ({'l_hip_pitch': -1.6, 'r_hip_pitch': -1.6, 'l_knee': 2.2, 'r_knee': 2.2,
           'l_ankle': -0.6, 'r_ankle': -0.6, 'spine_pitch': 0.5, 'l_shoulder_pitch': -0.8,
           'r_shoulder_pitch': -0.8}, (0.0, 0.0, 0.5), (0.0, 0.0))
_BACK = (_ARMS_DOWN, (0.3, 0.0, 0.145), (0.0, -np.pi / 2))
_FRONT = (_ARMS_DOWN, (0.6, 0.0, 0.145), (0.0, np.pi / 2))
# On hands and knees: the trunk level, thighs upright, arms straight down to the floor.
_ALL_FOURS = ({'l_hip_pitch': -1.5, 'r_hip_pitch': -1.5, 'l_knee': 1.55, 'r_knee': 1.55,
               'l_shoulder_pitch': -1.5, 'r_shoulder_pitch': -1.5, 'l_ankle': 0.5,
               'r_ankle': 0.5}, (0.15, 0.0, 0.56), (0.0, 1.5))


def _key_frames(skeleton, keys, start_s=10.0):
    """Return JointState content through key poses: (seconds to reach it, pose) each.

    :param skeleton: the character.
    :param keys: the first pose, then (seconds, pose) to each next one (a hold: the same pose).
    """
    from jacket_cloth_ros.core.inputs import WORLD_VARIABLES
    from jacket_cloth_ros.core.transforms import matrix_to_quat, rpy_matrix
    names = list(skeleton.joint_names) + [f'world_joint/{v}' for v in WORLD_VARIABLES]
    out, t = [], 0.0
    frames = [(0.0, keys[0])] + list(keys[1:])
    for (_, a), (seconds, b) in zip(frames, frames[1:]):
        n = max(1, int(round(seconds * RATE)))
        for k in range(1 if out else 0, n + 1):
            w = float(smoothstep(k / n))
            q = {j: (1 - w) * a[0].get(j, 0.0) + w * b[0].get(j, 0.0)
                 for j in set(a[0]) | set(b[0])}
            xyz = [(1 - w) * u + w * v for u, v in zip(a[1], b[1])]
            roll, pitch = ((1 - w) * u + w * v for u, v in zip(a[2], b[2]))
            turn = rpy_matrix([roll, 0.0, 0.0]) @ rpy_matrix([0.0, pitch, 0.0])
            joints = [q.get(j, 0.0) for j in skeleton.joint_names]
            # Between two key poses a straight blend can put a foot or a hand through the
            # floor: the body is lifted until every joint clears it, as a real one would be.
            low = xyz[2] + (skeleton.forward(np.array(joints))[:, :3, 3] @ turn[2]).min()
            xyz[2] += max(0.0, JOINT_CLEARANCE_M - low)
            quat = matrix_to_quat(turn)
            pos = joints + xyz + [float(v) for v in quat]
            out.append((int(round((start_s + t + k / RATE) * 1e9)), names, pos))
        t += n / RATE
    return out


def _rolled(pose, roll):
    """Return the lying ``pose`` turned about the world's x (its long axis) by ``roll``.

    A log roll, the arms at the sides: it is lifted so that the trunk's ellipse rests on the
    floor, and on its side _key_frames lifts it onto the lower arm (at most 4 cm).
    """
    joints, (x, y, _), (_, pitch) = pose
    depth, width = 0.135, 0.18
    z = np.hypot(depth * np.cos(roll), width * np.sin(roll)) + 0.01
    return (joints, (x, y, z), (roll, pitch))


def _crawl(pose, ahead, side):
    """On all fours ``pose``, ``ahead`` m on, one knee and the other hand forward."""
    joints, (x, y, z), turn = pose
    lead, trail = ('l', 'r') if side else ('r', 'l')
    moved = {f'{lead}_hip_pitch': joints[f'{lead}_hip_pitch'] - 0.3,
             f'{trail}_hip_pitch': joints[f'{trail}_hip_pitch'] + 0.15,
             f'{trail}_shoulder_pitch': joints[f'{trail}_shoulder_pitch'] - 0.3,
             f'{lead}_shoulder_pitch': joints[f'{lead}_shoulder_pitch'] + 0.15}
    return ({**joints, **moved}, (x + ahead, y, z), turn)


def floor_scenes(skeleton: Skeleton) -> list[Scene]:
    """Return the scenes where the body meets the floor, each from standing.

    :param skeleton: the shipped character.
    """
    def scene(name, *keys):
        # The calm tail holds the last pose: the idle joints at a root on the floor would
        # put the legs through it.
        return Scene(FLOOR + name, _key_frames(skeleton, [_STAND, *keys, (CALM_S, keys[-1][1])]),
                     ends_on_floor=keys[-1][1] is not _STAND)

    rolling = [(0.25, _rolled(_BACK, np.pi * k / 8)) for k in range(1, 17)]
    crawling = [(0.5, _crawl(_ALL_FOURS, 0.12 * k, k % 2)) for k in range(1, 9)]
    return [
        scene('kneeling', (1.2, _KNEEL), (1.5, _KNEEL), (1.2, _STAND)),
        scene('sitting on the floor', (1.0, _SQUAT), (1.0, _SIT), (2.0, _SIT)),
        scene('lying on the back', (1.0, _SQUAT), (1.0, _SIT), (1.2, _BACK),
              (2.0, _BACK)),
        scene('lying on the front', (1.2, _KNEEL), (1.2, _ALL_FOURS), (1.2, _FRONT),
              (2.0, _FRONT)),
        scene('rolling', (1.0, _SQUAT), (1.0, _SIT), (1.2, _BACK),
              (0.5, _rolled(_BACK, 0.0)), *rolling, (1.0, _rolled(_BACK, 2 * np.pi))),
        scene('crawling', (1.2, _KNEEL), (1.2, _ALL_FOURS), *crawling),
        scene('getting up', (1.2, _KNEEL), (1.2, _ALL_FOURS), (1.2, _FRONT),
              (1.0, _FRONT), (1.2, _ALL_FOURS), (1.2, _KNEEL), (1.2, _STAND)),
    ]


def _skinned(sim):
    """Return the cloth where the skinned pose puts it (the top row pinned)."""
    ref = sim.reference_points(sim.links, sim.layer)
    ref[:sim.rig.cols] = sim.pinned_points(sim.links, sim.layer)
    return ref


def _flipped_share(rig, x, ref):
    """Return the share of the grid's triangles facing the other way in ``x`` than in ``ref``."""
    tri = grid_triangles(rig.rows, rig.cols).reshape(-1, 3)

    def normals(p):
        a, b, c = p[tri[:, 0]], p[tri[:, 1]], p[tri[:, 2]]
        return np.cross(b - a, c - a)
    return float(((normals(x) * normals(ref)).sum(axis=1) < 0).mean())


_CONVERGED = {}


def _converged_end(skeleton, rig, scene, fabric_name):
    """Return the cloth at the end of ``scene`` run converged (the floor scenes' yardstick)."""
    key = (id(skeleton), id(rig), scene.name, fabric_name)
    if key not in _CONVERGED:
        fabric = load_fabric(fabric_name).with_values(**{**scene.fabric,
                                                         'iterations': REFERENCE_SWEEPS})
        sim = JacketSimulation(skeleton, rig, fabric,
                               SimParams(substeps=REFERENCE_SUBSTEPS, **scene.params))
        for stamp, names, pos in scene.inputs:
            sim.process(stamp, names, pos)
        _CONVERGED[key] = sim.x.copy()
    return _CONVERGED[key]


def run_scene(skeleton: Skeleton, rig: Rig, scene: Scene, method: str,
              fabric_name: str = 'tweed_jacket',
              end_frames: list | None = None) -> tuple[str, dict]:
    """Judge one method on one scene: 'holds' or how it failed, and the figures.

    :param skeleton: the character.
    :param rig: its rig.
    :param scene: the inputs, and the parameters and fabric values it changes.
    :param method: a stretch limit, ``xpbd+<stretch limit>`` for XPBD as the solver.
    :param fabric_name: the fabric preset the scene's values change.
    :param end_frames: if given, the scene's last moment is appended to it as a picture's
        frame (tools.picture.Frame): the jacket and hood on the body.
    """
    fabric = load_fabric(fabric_name).with_values(**scene.fabric)
    solver, _, limit = method.rpartition('+')
    params = SimParams(stretch_limit=limit, solver=solver or 'gauss_seidel', **scene.params)
    sim = JacketSimulation(skeleton, rig, fabric, params)
    nonfinite = 0
    worst_offset = 0.0
    worst_tunnel = 0.0
    worst_stretch = 0.0
    hem = slice((rig.rows - 1) * rig.cols, rig.n)
    settle_from = scene.inputs[-1][0] - SETTLE_S * 1e9
    hem_last, hem_path = None, np.zeros(rig.cols)
    for stamp, names, pos in scene.inputs:
        report = sim.process(stamp, names, pos)
        if stamp >= settle_from:        # the whole window, whatever the phase of a cycle
            if hem_last is not None:
                hem_path += np.linalg.norm(sim.x[hem] - hem_last, axis=1)
            hem_last = sim.x[hem].copy()
        if report.reset == 'non-finite cloth state':
            nonfinite += 1
        if not report.accepted or sim.last is None:
            continue
        ref = sim.reference_points(sim.links, sim.layer)
        worst_offset = max(worst_offset, float(np.linalg.norm(sim.x - ref, axis=1).max()))
        worst_tunnel = max(worst_tunnel, deepest_inside(sim))
        worst_stretch = max(worst_stretch, edge_strain(sim.x, rig.vert_a, rig.vert_b,
                                                       rig.vert_rest)[0].value)
    if end_frames is not None:
        from jacket_cloth_ros.tools.picture import sim_frame    # matplotlib: only if drawn
        end_frames.append(sim_frame(sim, scene.inputs[-1][0]))
    ref = (_converged_end(skeleton, rig, scene, fabric_name) if scene.ends_on_floor
           else _skinned(sim))
    figures = {
        'nonfinite': nonfinite,
        'max_offset_m': worst_offset,
        'max_inside_m': worst_tunnel,
        'flipped_share_end': _flipped_share(rig, sim.x, ref),
        'vertical_strain_end': sim.strain()[0],
        'max_vertical_stretch': worst_stretch,
        'hem_offset_end_m': float(np.linalg.norm(sim.x[hem] - ref[hem], axis=1).mean()),
        'hem_path_end_m': float(hem_path.mean()),
        'yardstick': 'converged' if scene.ends_on_floor else 'skinned',
        'resets': sim.resets,
        'overruns': sim.faults.overruns,
    }
    if nonfinite or not np.isfinite(sim.x).all():
        verdict = 'non-finite'
    elif worst_offset > EXPLODED_M:
        verdict = 'exploded'
    elif worst_tunnel > TUNNEL_M:
        verdict = 'tunnelled'
    elif figures['flipped_share_end'] > FLIPPED_SHARE:
        verdict = 'knotted/flipped'
    elif worst_stretch > VERTICAL_BOUND:
        verdict = 'stretched'
    elif scene.ends_on_floor and figures['hem_path_end_m'] > SETTLE_M:
        verdict = 'did not settle'
    elif figures['hem_offset_end_m'] > RECOVER_M:
        verdict = 'did not recover'
    else:
        verdict = 'holds'
    return verdict, figures


def stress(methods: Sequence[str] = METHODS, loop_s: float = 60.0,
           end_frames: dict | None = None, pictured: str = 'hard_pass') -> dict:
    """Every method on every scene: {(scene, method): (verdict, figures)}.

    :param methods: stretch limits, ``xpbd+<stretch limit>`` for XPBD as the solver.
    :param loop_s: how long the looped walk runs, seconds.
    :param end_frames: if given, filled with {scene: its last moment} of ``pictured`` (the
        pictures' cloth, tools.picture.Frame).
    :param pictured: the method whose last moments are kept (the shipped default's).
    """
    skeleton = load_shipped_character()
    rig = load_rig(skeleton)
    out = {}
    for scene in scenes(skeleton, loop_s):
        for method in methods:
            frames = [] if end_frames is not None and method == pictured else None
            out[(scene.name, method)] = run_scene(skeleton, rig, scene, method,
                                                  end_frames=frames)
            if frames:
                end_frames[scene.name] = frames[0]
    return out


def write_cloth(results: dict, end_frames: dict, method: str, out_dir: str) -> list[str]:
    """stress_cloth.png and stress_floor.png: each scene's last moment, jacket on the body.

    The scenes on their feet in one, those that end on the floor in the other; each column
    titled with the scene and the method's verdict.

    :param results: what :func:`stress` returned.
    :param end_frames: the scenes' last moments, as :func:`stress` filled them.
    :param method: the method they are of.
    :param out_dir: the folder the pictures go to.
    :returns: the pictures written.
    """
    import os

    from jacket_cloth_ros.tools.picture import draw_filmstrip
    skeleton = load_shipped_character()
    axes = load_rig(skeleton).view_axes()
    floor = [n for n in end_frames if n.startswith(FLOOR)]
    written = []
    for name, picked in (('stress_cloth.png', [n for n in end_frames if n not in floor]),
                         ('stress_floor.png', floor)):
        if not picked:
            continue
        path = os.path.join(out_dir, name)
        draw_filmstrip([end_frames[n] for n in picked], skeleton, path, 0,
                       title=f'each stress scene\'s last moment, {method}: the jacket and '
                       'hood on the body',
                       world_axes=axes, columns=[
                           f'{n.removeprefix(FLOOR)}\n{results[(n, method)][0]}'
                           for n in picked])
        written.append(path)
    return written


def write_matrix(results: dict, out_dir: str, methods: Sequence[str]) -> None:
    """stress.md, stress.json and stress.png: scene x method -> verdict.

    :param results: what :func:`stress` returned.
    :param out_dir: the folder the files go to.
    :param methods: the methods, the matrix's columns in order.
    """
    import json
    import os

    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    os.makedirs(out_dir, exist_ok=True)
    scene_names = list(dict.fromkeys(s for s, _ in results))
    lines = ['# Stress matrix', '', '| scene | ' + ' | '.join(methods) + ' |',
             '|---' * (len(methods) + 1) + '|']
    for scene in scene_names:
        cells = []
        for m in methods:
            verdict, f = results[(scene, m)]
            cells.append(f'{verdict} (inside {f["max_inside_m"] * 100:.1f} cm, stretch '
                         f'{f["max_vertical_stretch"] * 100:.1f} %)')
        lines.append(f'| {scene} | ' + ' | '.join(cells) + ' |')
    lines += ['', f'Bounds: exploded > {EXPLODED_M} m from the skinned pose; tunnelled > '
              f'{TUNNEL_M * 100:.0f} cm inside a collider; knotted/flipped > '
              f'{FLIPPED_SHARE:.0%} of triangles reversed after the scene, stretched: a '
              f'vertical edge > {VERTICAL_BOUND:.0%} over rest at any input, did not recover: '
              f'hem > {RECOVER_M * 100:.0f} cm from the skinned hem {CALM_S} s after the '
              f'scene. A scene that ends on the floor (the skinned pose inside it) is set '
              f'against the converged cloth ({REFERENCE_SWEEPS} sweeps, {REFERENCE_SUBSTEPS} '
              f'substeps) instead, and did not settle: a hem path > {SETTLE_M * 100:g} cm in '
              f'the last {SETTLE_S} s.', '']
    with open(os.path.join(out_dir, 'stress.md'), 'w', encoding='utf-8') as f:
        f.write('\n'.join(lines))
    with open(os.path.join(out_dir, 'stress.json'), 'w', encoding='utf-8') as f:
        json.dump([{'scene': s, 'method': m, 'verdict': v, **fig}
                   for (s, m), (v, fig) in results.items()], f, indent=2)
    fig, ax = plt.subplots(figsize=(2.2 * len(methods) + 3.5, 0.5 * len(scene_names) + 1.2))
    for i, scene in enumerate(scene_names):
        for j, m in enumerate(methods):
            verdict = results[(scene, m)][0]
            ax.add_patch(plt.Rectangle((j, i), 1, 1, color=(0.6, 0.85, 0.6)
                                       if verdict == 'holds' else (0.95, 0.6, 0.55)))
            ax.text(j + 0.5, i + 0.5, verdict, ha='center', va='center', fontsize=8)
    ax.set_xlim(0, len(methods))
    ax.set_ylim(len(scene_names), 0)
    ax.set_xticks([j + 0.5 for j in range(len(methods))], methods, fontsize=8)
    ax.set_yticks([i + 0.5 for i in range(len(scene_names))], scene_names, fontsize=8)
    ax.set_title('jacket_cloth stress: does each method hold? (stretch_limit)', fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, 'stress.png'), dpi=100)
    plt.close(fig)
