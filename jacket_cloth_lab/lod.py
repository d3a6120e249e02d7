# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth_lab bench lod``: cost and error of the level of detail against distance.

One clip per run with the viewer held at a distance from the character (core/lod.py); cost is
the measured CPU time of ``process()`` per simulated second, error the cloth's against the
same clip at full detail (no viewer), both measured in one process, side by side. Then a
crowd (issue 23 item 5): N characters spread evenly from 0 to CROWD_SPREAD_M from the viewer,
stepped together (core/crowd.py) with the level of detail on and off, alternately.
"""

import json
import os
import time
from typing import Sequence

import numpy as np

from jacket_cloth_ros.core.fabric import load_fabric
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.simulation import JacketSimulation, SimParams
from jacket_cloth_ros.core.skeleton import load_shipped_character
from .accuracy import CLIP_RATE, clip_inputs

DISTANCES = (None, 5.0, 12.0, 20.0, 35.0, 60.0)      # m; None: no viewer, full detail
REPEATS = 3                                             # interleaved, the median kept
CROWDS = (4, 16, 64)                                    # characters
CROWD_SPREAD_M = 60.0                                   # the farthest character's distance


def _run(skeleton, rig, fabric, inputs, distance):
    sim = JacketSimulation(skeleton, rig, fabric, SimParams())
    joints = len(skeleton.joint_names)
    xs, spent, levels = [], [], []
    for stamp, names, pos in inputs:
        root = np.asarray(pos[joints:joints + 3], dtype=float)
        sim.set_viewer(None if distance is None else root + [distance, 0.0, 0.0])
        t0 = time.thread_time_ns()
        report = sim.process(stamp, names, pos)
        spent.append(time.thread_time_ns() - t0)
        xs.append(sim.x.copy())
        levels.append(report.lod_level)
    return np.array(xs), np.array(spent[1:]), levels


def lod_bench(clip: str = 'walk', seconds: float = 3.0,
              distances: Sequence[float | None] = DISTANCES, repeats: int = REPEATS) -> dict:
    """Return per distance: level reached, cost (ms/s and against full detail), error (m).

    :param clip: the motion clip.
    :param seconds: its length.
    :param distances: the viewer's distances from the root, metres; None: no viewer, full detail
        (the error's reference, so it must be among them).
    :param repeats: runs at each distance, interleaved; the median cost is kept.
    """
    skeleton = load_shipped_character()
    rig = load_rig(skeleton)
    fabric = load_fabric('tweed_jacket')
    inputs = clip_inputs(skeleton, clip, seconds)
    costs = {d: [] for d in distances}
    shapes, levels = {}, {}
    for _ in range(repeats):
        for d in distances:
            xs, spent, lv = _run(skeleton, rig, fabric, inputs, d)
            costs[d].append(float(np.median(spent)) * 1e-6 * CLIP_RATE)
            shapes[d], levels[d] = xs, lv
    full = shapes[None]
    out = []
    for d in distances:
        err = np.linalg.norm(shapes[d] - full, axis=2)
        out.append({'distance_m': d, 'level': max(levels[d]),
                    'cost_ms_per_s': float(np.median(costs[d])),
                    'cost_vs_full': float(np.median(costs[d]) / np.median(costs[None])),
                    'cloth_rms_m': float(np.sqrt((err ** 2).mean())),
                    'cloth_max_m': float(err.max())})
    return {'clip': clip, 'seconds': seconds, 'lod_distances': list(SimParams().lod_distances),
            'rows': out}


def _crowd_run(skeleton, rig, fabric, inputs, n, lod, threads):
    from jacket_cloth_ros.core.crowd import CrowdSteps, stepped
    steps = CrowdSteps(threads=threads)
    for _ in range(n):
        steps.add(JacketSimulation(skeleton, rig, fabric, SimParams()))
    distances = np.linspace(0.0, CROWD_SPREAD_M, n) if n > 1 else np.zeros(1)
    joints = len(skeleton.joint_names)
    spent, levels = [], np.zeros(3, dtype=int)
    for k, (stamp, names, pos) in enumerate(inputs):
        root = np.asarray(pos[joints:joints + 3], dtype=float)
        for sim, d in zip(steps.sims, distances):
            sim.set_viewer(root + [d, 0.0, 0.0] if lod else None)
        t0 = time.process_time_ns()             # every thread of the process: the whole call
        reports = stepped(steps, [(i, stamp, names, pos) for i in range(n)])
        if k:                                   # the first input is the reset
            spent.append(time.process_time_ns() - t0)
            for r in reports:
                levels[r.lod_level] += 1
    return float(np.median(spent)), levels


def crowd_lod_bench(crowds: Sequence[int] = CROWDS, seconds: float = 2.0,
                    repeats: int = REPEATS, threads: int = 1) -> dict:
    """Return per crowd size: CPU per character-input with the level of detail on and off.

    :param crowds: the crowd sizes, characters.
    :param seconds: the walk's length.
    :param repeats: runs of each size, on and off alternately; the median is kept.
    :param threads: the crowd call's threads (1: one core, the issue's first target).
    """
    skeleton = load_shipped_character()
    rig = load_rig(skeleton)
    fabric = load_fabric('tweed_jacket')
    inputs = clip_inputs(skeleton, 'walk', seconds)
    rows = []
    for n in crowds:
        cost = {True: [], False: []}
        for _ in range(repeats):
            for lod in (False, True):
                spent, levels = _crowd_run(skeleton, rig, fabric, inputs, n, lod, threads)
                cost[lod].append(spent / n)
                if lod:
                    on_levels = levels
        off, on = float(np.median(cost[False])), float(np.median(cost[True]))
        rows.append({'characters': n, 'us_per_character_off': off * 1e-3,
                     'us_per_character_on': on * 1e-3, 'on_vs_off': on / off,
                     'inputs_per_level': [int(v) for v in on_levels]})
    return {'spread_m': CROWD_SPREAD_M, 'threads': threads, 'seconds': seconds,
            'lod_distances': list(SimParams().lod_distances), 'rows': rows}


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def _save(out_dir, stem, results, lines, fig):
    """Write STEM.json (the results), STEM.md (the table's lines) and STEM.png (the figure)."""
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, f'{stem}.json'), 'w', encoding='utf-8') as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(out_dir, f'{stem}.md'), 'w', encoding='utf-8') as f:
        f.write('\n'.join(lines) + '\n')
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, f'{stem}.png'), dpi=100)
    _pyplot().close(fig)


def write_crowd(results: dict, out_dir: str) -> None:
    """crowd_lod.json, crowd_lod.md and crowd_lod.png.

    :param results: what :func:`crowd_lod_bench` returned.
    :param out_dir: the folder the files go to.
    """
    plt = _pyplot()
    lines = [f'# A crowd spread from 0 to {results["spread_m"]:g} m, level of detail on and off '
             f'(walk, {results["seconds"]} s, {results["threads"]} thread(s), lod_distances '
             f'{results["lod_distances"]})', '',
             '| characters | CPU us per character-input, off | on | on / off '
             '| inputs at level 0 / 1 / 2 |', '|---' * 5 + '|']
    for r in results['rows']:
        lines.append(f'| {r["characters"]} | {r["us_per_character_off"]:.0f} | '
                     f'{r["us_per_character_on"]:.0f} | {r["on_vs_off"]:.2f} | '
                     + ' / '.join(str(v) for v in r['inputs_per_level']) + ' |')
    n = [r['characters'] for r in results['rows']]
    fig, a = plt.subplots(figsize=(6.4, 3.6))
    a.plot(n, [r['us_per_character_off'] for r in results['rows']], 'o-', label='LOD off')
    a.plot(n, [r['us_per_character_on'] for r in results['rows']], 's-', label='LOD on')
    a.set_xscale('log', base=2)
    a.set_xlabel('characters, spread evenly 0 to %g m from the viewer' % results['spread_m'])
    a.set_ylabel('CPU per character-input (us)')
    a.set_ylim(bottom=0)
    a.legend()
    a.set_title('A crowd with the level of detail on and off (offline, one call per round)',
                fontsize=9)
    _save(out_dir, 'crowd_lod', results, lines, fig)


def write(results: dict, out_dir: str) -> None:
    """lod.json, lod.md and lod.png.

    :param results: what :func:`lod_bench` returned.
    :param out_dir: the folder the files go to.
    """
    plt = _pyplot()
    lines = [f'# Level of detail against distance ({results["clip"]}, {results["seconds"]} s, '
             f'lod_distances {results["lod_distances"]})', '',
             '| viewer at m | level | cost ms/s | cost vs full | cloth RMS vs full cm '
             '| max cm |', '|---' * 6 + '|']
    for r in results['rows']:
        d = 'none' if r['distance_m'] is None else f'{r["distance_m"]:g}'
        lines.append(f'| {d} | {r["level"]} | {r["cost_ms_per_s"]:.1f} | '
                     f'{r["cost_vs_full"]:.2f} | {r["cloth_rms_m"] * 100:.2f} | '
                     f'{r["cloth_max_m"] * 100:.2f} |')
    rows = [r for r in results['rows'] if r['distance_m'] is not None]
    fig, a = plt.subplots(figsize=(6.4, 3.6))
    dist = [r['distance_m'] for r in rows]
    a.plot(dist, [r['cost_vs_full'] for r in rows], 'o-', color='tab:blue')
    a.set_xlabel('viewer distance (m)')
    a.set_ylabel('cost / full detail', color='tab:blue')
    b = a.twinx()
    b.plot(dist, [r['cloth_rms_m'] * 100 for r in rows], 's--', color='tab:red')
    b.set_ylabel('cloth RMS vs full detail (cm)', color='tab:red')
    for x in results['lod_distances']:
        a.axvline(x, color='k', ls=':', lw=0.8)
    a.set_title(f'Level of detail: cost and error against distance ({results["clip"]})',
                fontsize=9)
    _save(out_dir, 'lod', results, lines, fig)
