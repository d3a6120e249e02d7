# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth_lab bench``: every method's error against its measured cost, per motion clip.

For each clip the lab computes both converged references (``accuracy.reference``: XPBD's model
and the article's Gauss-Seidel model), how far apart they are and how the Gauss-Seidel one
converges with sweeps and steps, then runs the sweep (methods x iterations x substeps x
step) through ``JacketSimulation.process`` and times it: cost is the measured CPU time per
simulated second on this machine, not a model. It also runs the exact references (pendulum,
hanging chain), the automatic quality mode against the fixed default, and the rig-detail
study: the converged cloth of coarser grids and of fewer colliders against the finest grid's.
"""

import copy
import json
import os
from dataclasses import replace
from typing import Callable, Sequence

import numpy as np

from jacket_cloth_ros.core.config import load_yaml, shipped
from jacket_cloth_ros.core.fabric import Fabric, load_fabric
from jacket_cloth_ros.core.rig import Rig
from jacket_cloth_ros.core.skeleton import Skeleton, load_shipped_character
from . import accuracy
from .accuracy import SHIPPED, Method

CLIPS = ('idle', 'walk', 'run', 'dodge', 'jump', 'arms_up', 'turn')
CLIP_SECONDS = 3.0
FAMILIES = (('gauss_seidel', 'none'), ('gauss_seidel', 'hard_pass'), ('gauss_seidel', 'tethers'),
            ('xpbd', 'none'), ('xpbd', 'hard_pass'))
GRIDS = ((5, 7), (7, 9), (9, 12), (13, 18))       # cols x rows; 9x12 ships
TOLERANCES = (0.002, 0.005, 0.01, 0.02)           # m, the automatic mode's settings measured
AUTO_BUDGET = {'substeps': 2, 'iterations': 16}   # the most the automatic mode may spend
PENDULUM = ((60.0, 120.0, 240.0), (10.0, 60.0, 120.0, 170.0))   # rates (Hz) x amplitudes (deg)


QUICK_CONVERGENCE = {'sweeps': (8, 16, 32), 'rates': (240.0, 480.0, 960.0)}
# The default's rivals: those that hold every stress scene (M12) at one step per 120 Hz, timed
# against it in turns. The sweep times each method once, so the host's drift between two runs
# is in their cost ratio; in turns it reaches every method alike.
RIVALS = (Method('gauss_seidel', 'hard_pass', 16), Method('xpbd', 'hard_pass', 8))
ROUNDS = 5
# Each method of the sweep is timed this many times, round-robin over the sweep, with nothing
# but the simulation between inputs, and its cost is the fastest: the host's slow phases (the
# kernel at up to 1.6x for seconds) only add time, and timed once they fell on some methods
# and not others.
COST_ROUNDS = 3


def reference_methods(quick: bool = False) -> tuple[Method, Method]:
    """Return the (XPBD, Gauss-Seidel) references.

    :param quick: whether the quick mode's, coarser (960 Hz, 32 sweeps).
    """
    if quick:
        return tuple(replace(m, sim_rate=960.0, iterations=32)
                     for m in (accuracy.REFERENCE, accuracy.GS_REFERENCE))
    return accuracy.REFERENCE, accuracy.GS_REFERENCE


def sweep(quick: bool = False) -> list[Method]:
    """Return the methods run on every clip.

    :param quick: whether the quick mode's few methods.
    """
    if quick:
        return [SHIPPED, Method('gauss_seidel', 'none'), Method('gauss_seidel', 'hard_pass', 2),
                Method('xpbd', 'none'), Method('xpbd', 'none', 4, 2),
                replace(SHIPPED, sim_rate=60.0)] + list(RIVALS)
    out = []
    for solver, limit in FAMILIES:
        for it in (1, 2, 4, 8, 16):
            for sub in (1, 2, 4):
                out.append(Method(solver, limit, it, sub))
        out += [Method(solver, limit, 8, 1, rate) for rate in (60.0, 240.0)]
    return out


def auto_methods(quick: bool = False) -> list[Method]:
    """Return the automatic quality mode at each tolerance, over the default method and budget.

    :param quick: whether the quick mode's one tolerance.
    """
    tolerances = TOLERANCES[2:3] if quick else TOLERANCES
    return [replace(SHIPPED, tolerance=t, **AUTO_BUDGET) for t in tolerances]


def rig_at_grid(skeleton: Skeleton, cols: int, rows: int,
                colliders: Sequence[str] | None = None) -> Rig:
    """Return the shipped rig with another grid over the same jacket, perhaps fewer colliders.

    Row spacing and flare are rescaled so the hem stays where it is; region ranges scale with
    the grid.

    :param skeleton: the shipped character.
    :param cols: the grid's vertex columns.
    :param rows: the grid's vertex rows.
    :param colliders: the names of the colliders kept; None: all.
    """
    data = copy.deepcopy(load_yaml(shipped('jacket_rig.yaml')))
    cloth = data['cloth']
    rs = (cloth['rows'] - 1) / (rows - 1)
    cs = (cloth['cols'] - 1) / (cols - 1)
    cloth['shape']['row_spacing'] *= rs
    cloth['shape']['flare'] *= rs
    for region in cloth.get('regions', []):
        region['rows'] = [min(rows - 1, int(round(r / rs))) for r in region['rows']]
        region['cols'] = [min(cols - 1, int(round(c / cs))) for c in region['cols']]
    cloth['cols'], cloth['rows'] = cols, rows
    if colliders is not None:
        data['colliders'] = [c for c in data['colliders'] if c['name'] in colliders]
    return Rig(data, skeleton, where=f'shipped rig at {cols}x{rows}')


def pareto_front(rows: Sequence[dict],
                 error: Callable[[dict], float] = lambda r: r['hem_rms_m']) -> list[int]:
    """Return the indices of the rows no other row beats on both cost and error.

    :param rows: the runs' figures, ``cost_ms_per_s`` in each.
    :param error: a run's error, its figures given.
    """
    order = sorted(range(len(rows)), key=lambda i: (rows[i]['cost_ms_per_s'], error(rows[i])))
    front, best = [], np.inf
    for i in order:
        if error(rows[i]) < best:
            front.append(i)
            best = error(rows[i])
    return front


def _gs_error(row):
    return row['vs_gs']['hem_rms_m']


def bench(clips: Sequence[str] = CLIPS, quick: bool = False, seconds: float = CLIP_SECONDS,
          fabric_name: str = 'tweed_jacket',
          progress: Callable[[str], None] | None = None) -> dict:
    """Run everything; a JSON-ready dict of results.

    :param clips: the motion clips run.
    :param quick: whether the quick mode: fewer methods, coarser references.
    :param seconds: each clip's length.
    :param fabric_name: the fabric preset.
    :param progress: called with a line of text as each part goes.
    """
    say = progress or (lambda text: None)
    skeleton = load_shipped_character()
    fabric = load_fabric(fabric_name)
    rig = rig_at_grid(skeleton, 9, 12)
    ref_method, gs_method = reference_methods(quick)
    out = {'fabric': fabric_name, 'quick': quick, 'clip_seconds': seconds,
           'reference': ref_method.label, 'gs_reference': gs_method.label,
           'default': SHIPPED.label, 'clips': {}}
    for clip in clips:
        inputs = accuracy.clip_inputs(skeleton, clip, seconds)
        say(f'{clip}: references ({ref_method.label}; {gs_method.label}) and their checks')
        ref, richardson = accuracy.reference(skeleton, rig, fabric, inputs, ref_method)
        gs_ref, gs_richardson, gs_check = accuracy.reference(skeleton, rig, fabric, inputs,
                                                             gs_method, keep_check=True)
        methods = sweep(quick) + auto_methods(quick)
        rows = [accuracy.metrics(accuracy.run(skeleton, rig, fabric, m, inputs), ref, gs_ref)
                for m in methods]
        # The runs above took figures between inputs; these time the simulation alone.
        costs = in_turns(skeleton, rig, fabric, inputs, methods, 2 if quick else COST_ROUNDS)
        for row, cost in zip(rows, costs.values()):
            row['cost_ms_per_s'], row['cost_rounds'] = min(cost), cost
        fixed = [i for i, r in enumerate(rows) if not r['tolerance_m']]
        for i in pareto_front([rows[i] for i in fixed]):
            rows[fixed[i]]['pareto'] = True
        for i in pareto_front([rows[i] for i in fixed], _gs_error):
            rows[fixed[i]]['pareto_gs'] = True
        say(f'{clip}: the default against its rivals, in turns')
        out['clips'][clip] = {'head_to_head': head_to_head(
                                  skeleton, rig, fabric, inputs, (SHIPPED,) + RIVALS,
                                  2 if quick else ROUNDS),
                              'richardson': richardson, 'gs_richardson': gs_richardson,
                              'references_apart': accuracy.compare(gs_ref, ref),
                              'gs_convergence': accuracy.convergence(
                                  skeleton, rig, fabric, inputs, gs_method, best=gs_check,
                                  **(QUICK_CONVERGENCE if quick else {})),
                              'rows': rows}
        say(f'{clip}: {len(rows)} runs')
    out['pendulum'] = [accuracy.pendulum(skeleton, rig, fabric, rate, theta)
                       for rate in (PENDULUM[0][1:2] if quick else PENDULUM[0])
                       for theta in PENDULUM[1]]
    chain_methods = ([SHIPPED, Method('gauss_seidel', 'none'), Method('xpbd', 'none')] if quick
                     else [Method(s, lim, it, sub) for s, lim in FAMILIES
                           for it, sub in ((2, 1), (8, 1), (2, 4))])
    out['chain'] = [accuracy.hanging_chain(fabric, m) for m in chain_methods]
    out['rig_detail'] = rig_detail(skeleton, fabric, clips[:1] if quick else clips, seconds,
                                   ref_method, quick, say)
    return out


def in_turns(skeleton: Skeleton, rig: Rig, fabric: Fabric, inputs: Sequence[accuracy.Input],
             methods: Sequence[Method], rounds: int) -> dict[str, list[float]]:
    """Time methods round-robin on one clip: each round runs every method once.

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset.
    :param inputs: the clip's JointStates.
    :param methods: the methods, each label once.
    :param rounds: how many rounds.
    :returns: label -> its cost (ms per simulated s) in each round.
    """
    cost = {m.label: [] for m in methods}
    for _ in range(rounds):
        for m in methods:
            cost[m.label].append(accuracy.timed_cost(skeleton, rig, fabric, m, inputs))
    return cost


def head_to_head(skeleton: Skeleton, rig: Rig, fabric: Fabric, inputs: Sequence[accuracy.Input],
                 methods: Sequence[Method], rounds: int) -> dict:
    """Time methods in turns on one clip; each one's cost against the first's.

    :param skeleton: the character.
    :param rig: its rig.
    :param fabric: the fabric preset.
    :param inputs: the clip's JointStates.
    :param methods: the methods; the first is what the others are compared with.
    :param rounds: how many turns each method runs.
    :returns: ``{'rounds', 'cost_ms_per_s': {label: [one per round]}, 'vs_first': {label:
        median over rounds of its cost / the first's in that round}}``.
    """
    cost = in_turns(skeleton, rig, fabric, inputs, methods, rounds)
    first = cost[methods[0].label]
    return {'rounds': rounds, 'cost_ms_per_s': cost,
            'vs_first': {label: float(np.median(np.divide(c, first)))
                         for label, c in cost.items()}}


def rig_detail(skeleton: Skeleton, fabric: Fabric, clips: Sequence[str], seconds: float,
               ref_method: Method, quick: bool, say: Callable[[str], None]) -> list[dict]:
    """Converged cloth of each grid and collider set against the finest grid's, per clip.

    :param skeleton: the shipped character.
    :param fabric: the fabric preset.
    :param clips: the motion clips run.
    :param seconds: each clip's length.
    :param ref_method: the converged method every rig runs with.
    :param quick: whether the quick mode's two grids.
    :param say: called with a line of text as each clip goes.
    """
    grids = GRIDS[1:3] if quick else GRIDS
    variants = [(f'{c}x{r}', rig_at_grid(skeleton, c, r)) for c, r in grids]
    variants.append(('9x12, no thigh colliders',
                     rig_at_grid(skeleton, 9, 12, colliders=('torso', 'pelvis', 'floor'))))
    finest = variants[len(grids) - 1][1]
    out = []
    for clip in clips:
        inputs = accuracy.clip_inputs(skeleton, clip, seconds)
        say(f'{clip}: rig detail')
        best = accuracy.run(skeleton, finest, fabric, ref_method, inputs)
        for name, rig in variants:
            trace = accuracy.run(skeleton, rig, fabric, ref_method, inputs)
            shipped_method = accuracy.run(skeleton, rig, fabric, SHIPPED, inputs)
            row = {'clip': clip, 'rig': name, 'vertices': rig.n,
                   'constraints': len(rig.con_a),
                   'colliders': len(rig.colliders) + len(rig.capsules) + len(rig.planes),
                   'cost_ms_per_s': shipped_method.cost_ms_per_s}
            row.update(accuracy.compare(trace, best))
            out.append(row)
    return out


# -- output ---------------------------------------------------------------------------------------

def _mm(v):
    return f'{v * 1e3:.1f}'


def write(results: dict, out_dir: str) -> None:
    """bench.json, bench.md and the charts.

    :param results: what :func:`bench` returned.
    :param out_dir: the folder the files go to.
    """
    os.makedirs(out_dir, exist_ok=True)
    with open(os.path.join(out_dir, 'bench.json'), 'w', encoding='utf-8') as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(out_dir, 'bench.md'), 'w', encoding='utf-8') as f:
        f.write(markdown(results))
    charts(results, out_dir)


def markdown(results: dict) -> str:
    """Return bench.md: every table of the results.

    :param results: what :func:`bench` returned.
    """
    lines = ['# jacket_cloth bench', '',
             f'Fabric `{results["fabric"]}`, clips of {results["clip_seconds"]} s at 60 Hz '
             f'JointState. References, float64: XPBD\'s model ({results["reference"]}) and '
             f'the article\'s Gauss-Seidel model ({results["gs_reference"]}). Default: '
             f'{results["default"]}. Cost: measured CPU time of `process()` per simulated '
             'second on this machine (ms/s). Errors against the XPBD reference (mm), and hem '
             'RMS against the Gauss-Seidel one (vs GS). Strain: worst '
             '|l/L - 1| of simulated edges (%). Energy: mean kinetic energy / the reference\'s.',
             '']
    for clip, data in results['clips'].items():
        r, g, apart = data['richardson'], data['gs_richardson'], data['references_apart']
        conv = data['gs_convergence']
        lines += [f'## {clip}', '',
                  f'XPBD reference vs half its step (Richardson): hem RMS {_mm(r["hem_rms_m"])} '
                  f'mm, max {_mm(r["hem_max_m"])} mm; hood RMS {_mm(r["hood_rms_m"])} mm. '
                  f'Gauss-Seidel reference vs half its step and twice its sweeps: hem RMS '
                  f'{_mm(g["hem_rms_m"])} mm, max {_mm(g["hem_max_m"])} mm; every vertex RMS '
                  f'{_mm(g["cloth_rms_m"])} mm.', '',
                  f'The two references apart: every vertex RMS {apart["cloth_rms_m"] * 100:.2f} '
                  f'cm, max {apart["cloth_max_m"] * 100:.2f} cm; hem RMS '
                  f'{apart["hem_rms_m"] * 100:.2f} cm, max {apart["hem_max_m"] * 100:.2f} cm.', '',
                  f'Gauss-Seidel convergence, against {conv["against"]} (hem RMS / every vertex '
                  'RMS, mm): sweeps at the reference\'s rate '
                  + ', '.join(f'{c["iterations"]}: {_mm(c["hem_rms_m"])} / '
                              f'{_mm(c["cloth_rms_m"])}' for c in conv['sweeps'])
                  + '; rates at its sweeps '
                  + ', '.join(f'{c["sim_rate"]:g} Hz: {_mm(c["hem_rms_m"])} / '
                              f'{_mm(c["cloth_rms_m"])}' for c in conv['rates']) + '.', '',
                  '| method | cost ms/s | sweeps/step | hem RMS | hem max | hood RMS | hood max '
                  '| hem RMS vs GS | vertical % | horizontal % | shear % | inside mm | energy '
                  '| Pareto (XPBD / GS ref) |',
                  '|---' * 14 + '|']
        for row in sorted(data['rows'], key=lambda x: x['cost_ms_per_s']):
            mark = ' (default)' if row['label'] == results['default'] else ''
            lines.append(
                f'| {row["label"]}{mark} | {row["cost_ms_per_s"]:.1f} | '
                f'{row["sweeps_per_step"]:.1f} | {_mm(row["hem_rms_m"])} | '
                f'{_mm(row["hem_max_m"])} | {_mm(row["hood_rms_m"])} | {_mm(row["hood_max_m"])} | '
                f'{_mm(row["vs_gs"]["hem_rms_m"])} | {row["vertical_strain_max"] * 100:.1f} | '
                f'{row["horizontal_strain_max"] * 100:.1f} | {row["shear_strain_max"] * 100:.1f} '
                f'| {_mm(row["inside_max_m"])} | {row["energy_ratio"]:.2f} | '
                f'{"yes" if row.get("pareto") else ""} / '
                f'{"yes" if row.get("pareto_gs") else ""} |')
        lines.append('')
    lines += ['## Hood pendulum (M8) against T = 4 sqrt(L/g) K(sin(theta/2))', '',
              '| rate Hz | released at deg | first-cycle amplitude deg | period s | exact s | '
              'period error % | amplitude lost per cycle % |', '|---' * 7 + '|']
    for p in results['pendulum']:
        lines.append(f'| {p["sim_rate"]:g} | {p["theta0_deg"]:g} | {p["amplitude_deg"]:.1f} | '
                     f'{p["period_s"]:.4f} | {p["exact_s"]:.4f} | {p["period_error"] * 100:.2f} '
                     f'| {p["amplitude_loss_per_cycle"] * 100:.1f} |')
    lines += ['', '## Hanging chain: a 12-vertex column released horizontal, after 4 s', '',
              '| method | stretch % | worst link % | bottom from exact mm | settled (1 cm) at s |',
              '|---' * 5 + '|']
    for c in results['chain']:
        settle = f'{c["settle_s"]:.2f}' if c['settle_s'] is not None else 'never'
        lines.append(f'| {c["method"]} | {c["stretch"] * 100:.3f} | '
                     f'{c["worst_link_strain"] * 100:.3f} | {_mm(c["bottom_error_m"])} | '
                     f'{settle} |')
    lines += ['', '## Rig detail: converged cloth against the finest grid\'s', '',
              '| clip | rig | vertices | colliders | default cost ms/s | hem RMS mm '
              '| hem max mm |',
              '|---' * 7 + '|']
    for d in results['rig_detail']:
        lines.append(f'| {d["clip"]} | {d["rig"]} | {d["vertices"]} | {d["colliders"]} | '
                     f'{d["cost_ms_per_s"]:.1f} | {_mm(d["hem_rms_m"])} | '
                     f'{_mm(d["hem_max_m"])} |')
    return '\n'.join(lines) + '\n'


COLOURS = {'GS': 'tab:gray', 'GS+hard_pass': 'tab:blue', 'GS+tethers': 'tab:green',
           'XPBD': 'tab:orange', 'XPBD+hard_pass': 'tab:red'}


# Each chart's reference: (its name, the row's hem error, its Pareto mark, its own check).
REFERENCES = {'xpbd': ('XPBD', lambda r: r['hem_rms_m'], 'pareto', 'richardson'),
              'gs': ('Gauss-Seidel', _gs_error, 'pareto_gs', 'gs_richardson')}


def _pareto_axes(ax, clip, data, default_label, which='xpbd'):
    name, error, mark, check = REFERENCES[which]
    rows = data['rows']
    for family, colour in COLOURS.items():
        pts = [r for r in rows if r['method'] == family and not r['tolerance_m']]
        if pts:
            ax.scatter([r['cost_ms_per_s'] for r in pts], [error(r) * 1e3 for r in pts],
                       s=14, color=colour, label=family, alpha=0.8)
    auto = [r for r in rows if r['tolerance_m']]
    if auto:
        ax.scatter([r['cost_ms_per_s'] for r in auto], [error(r) * 1e3 for r in auto],
                   marker='s', s=22, facecolors='none', edgecolors='k', label='auto (tolerance)')
    front = sorted((r for r in rows if r.get(mark)), key=lambda r: r['cost_ms_per_s'])
    ax.step([r['cost_ms_per_s'] for r in front], [error(r) * 1e3 for r in front],
            where='post', color='k', lw=0.8, label='Pareto front')
    for r in rows:
        if r['label'] == default_label:
            ax.scatter([r['cost_ms_per_s']], [error(r) * 1e3], marker='*', s=160,
                       color='gold', edgecolors='k', zorder=5, label='shipped default')
    floor = data[check]['hem_rms_m'] * 1e3
    ax.axhline(max(floor, 1e-3), color='k', ls=':', lw=0.8, label='reference uncertainty')
    ax.set_xscale('log')
    ax.set_yscale('log')
    ax.set_xlabel('cost: CPU ms per simulated second')
    ax.set_ylabel(f'hem error, RMS vs converged {name} (mm)')
    ax.set_title(clip, fontsize=9)
    ax.grid(True, which='both', alpha=0.3)


def charts(results: dict, out_dir: str) -> None:
    """Draw the Pareto charts, per clip and of all clips, against each reference; convergence.

    :param results: what :func:`bench` returned.
    :param out_dir: the folder the PNG files go to.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    clips = list(results['clips'])
    for which, suffix in (('xpbd', ''), ('gs', '_gs')):
        for clip in clips:
            fig, ax = plt.subplots(figsize=(6.4, 4.4))
            _pareto_axes(ax, clip, results['clips'][clip], results['default'], which)
            ax.legend(fontsize=7)
            fig.tight_layout()
            fig.savefig(os.path.join(out_dir, f'pareto{suffix}_{clip}.png'), dpi=100)
            plt.close(fig)
        cols = min(4, len(clips))
        rows = (len(clips) + cols - 1) // cols
        fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False)
        for ax, clip in zip(axes.flat, clips):
            _pareto_axes(ax, clip, results['clips'][clip], results['default'], which)
            ax.xaxis.label.set_size(7)
            ax.yaxis.label.set_size(7)
        for ax in list(axes.flat)[len(clips):]:
            ax.axis('off')
        handles, labels = axes.flat[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc='lower right', fontsize=7, ncol=2)
        fig.suptitle(f'jacket_cloth bench: hem error against measured cost, per clip '
                     f'({REFERENCES[which][0]} reference)', fontsize=10)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, f'pareto{suffix}.png'), dpi=90)
        plt.close(fig)
    _convergence_chart(results, out_dir, plt)


def _convergence_chart(results, out_dir, plt):
    """gs_convergence.png: the Gauss-Seidel reference's error as sweeps, then rates, grow."""
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.6))
    for clip, data in results['clips'].items():
        conv = data['gs_convergence']
        a.plot([c['iterations'] for c in conv['sweeps']],
               [c['cloth_rms_m'] * 1e3 for c in conv['sweeps']], 'o-', label=clip)
        b.plot([c['sim_rate'] for c in conv['rates']],
               [c['cloth_rms_m'] * 1e3 for c in conv['rates']], 'o-', label=clip)
    for ax, what in ((a, 'sweeps per step (at the reference rate)'),
                     (b, 'rate, Hz (at the reference sweeps)')):
        ax.set_xscale('log', base=2)
        ax.set_yscale('log')
        ax.set_xlabel(what, fontsize=8)
        ax.set_ylabel('every vertex RMS vs the finer run (mm)', fontsize=8)
        ax.grid(True, which='both', alpha=0.3)
    a.legend(fontsize=7)
    fig.suptitle('Gauss-Seidel reference: error against its finer run (flat = converged)',
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, 'gs_convergence.png'), dpi=90)
    plt.close(fig)
