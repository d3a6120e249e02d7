# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s files: speed.json, speed.md (:func:`summary`) and the charts."""

import json
import os

import numpy as np

from .. import host_probe, profile
from ..crowd import chart as crowd_chart, summary as crowd_summary
from .measure import RATE, STEP_US
from .replay import replay_of_limit
from .targets import COST_ONLY


def _verdict(met: bool | None, target: str = '') -> str:
    if target == COST_ONLY:
        return 'a cost to know'
    return 'not measured' if met is None else 'met' if met else 'NOT MET'


def summary(results: dict) -> str:
    """Return speed.md: the parts' figures as ratios, with the steal each saw.

    :param results: what :func:`run` returned.
    """
    lines = ['# jacket_cloth bench speed', '']
    steal = results.get('steal_percent', {})
    if steal:
        lines += ['CPU steal (time the host gave other guests) while each part ran: ' + ', '.join(
            f'{k} {v:.0f} %' for k, v in steal.items()) + '.', '']
    if results.get('targets'):
        lines += ['## Targets', '', '| figure | measured | target | verdict |',
                  '|---|---|---|---|']
        lines += [f'| {t["figure"]} | {t["measured"]} | {t["target"]} | '
                  f'{_verdict(t["met"], t["target"])} |' for t in results['targets']]
        lines += ['']
    if 'host' in results:
        lines += host_probe.summary(results['host']) + ['']
    k = results.get('kernel', [])
    if k:
        lines += ['## Kernel against the C yardstick (one step, same grid and iterations)', '',
                  '| grid | constraints | iterations | kernel us | yardstick us | ratio |',
                  '|---|---|---|---|---|---|']
    for r in k:
        gated = ', quiet rounds' if r.get('counted') == 'quiet rounds' else ''
        lines.append(f'| {r["grid"]} | {r["constraints"]} | {r["iterations"]} | '
                     f'{r["kernel_ns"] / 1e3:.1f} | '
                     + (f'{r["limit_ns"] / 1e3:.1f} | {r["ratio"]:.2f}x{gated} |' if 'ratio' in r
                        else 'n/a | n/a |'))
    if 'profile' in results:
        lines += [''] + profile.summary(results['profile'])
    if 'hops' in results:
        lines += ['', '## From the JointState callback to the /tf publish', '',
                  'The deepest chain of the package\'s calls for one steady input: '
                  + ' -> '.join(results['hops']['chain']) + '; modules run: '
                  + ', '.join(results['hops']['files']) + '.']
    if 'input' not in results:           # --only a part
        if 'endurance' in results:
            lines += _endurance(results['endurance'])
        crowd = crowd_summary(results['crowd']) if 'crowd' in results else []
        return '\n'.join(lines + crowd) + '\n'
    i = results['input']
    lines += ['', f'Pipeline per JointState (120 Hz in, 120 Hz steps): median '
              f'{i["input_us_median"]:.0f} us CPU, kernel {i["kernel_us_median"]:.0f} us: '
              f'{i["ratio"]:.1f}x the kernel. Paced at 120 Hz (sleeping between inputs, as a '
              f'live node does): {i["paced_us_median"]:.0f} us, {i["paced_ratio"]:.1f}x the '
              f'kernel.', '']
    # The replay against the yardstick's own step at the shipped grid: 100x real time means
    # 83 us per 120 Hz step for everything, which no machine-independent figure promises.
    ref = [r for r in k if r['grid'] == '9x12' and r['iterations'] == 8 and 'limit_ns' in r]
    lines += ['Replay of a walk (JointState at 60 Hz, two 120 Hz steps each), default rig 9x12 '
              '8 iterations' + (f'; the yardstick\'s step at that grid: '
                                f'{ref[0]["limit_ns"] / 1e3:.1f} us' if ref else '') + '.', '',
              '| session s | replay s | x real time | us per step | per step / yardstick | '
              'share of the kernel-only limit |', '|---|---|---|---|---|---|']
    for r, share in zip(results['replay'], replay_of_limit(results)):
        per_step = r['replay_s'] / (r['session_s'] * RATE) * 1e6
        lines.append(f'| {r["session_s"]:g} | {r["replay_s"]:.2f} | {r["realtime_x"]:.1f} | '
                     f'{per_step:.1f} | ' + (f'{per_step / (ref[0]["limit_ns"] / 1e3):.2f}x | '
                                             if ref else 'n/a | ') + f'{share:.2f} |')
    lines += _endurance(results['endurance'])
    if 'node' in results:
        n = results['node']
        lat = n['latency_windows']
        lines += ['', f'Live node at 120 Hz, recording on: {len(n["rounds"])} rounds of node, '
                  'floor and bare floor run at once on one JointState stream (CPU per '
                  'message):', '',
                  '| round | node us | floor (with kernel) us | ratio | kernel share us | '
                  'bare floor + kernel b2b us | ratio |', '|---|---|---|---|---|---|---|']
        for k, x in enumerate(n['rounds']):
            lines.append(f'| {k + 1} | {x["node_us"]:.0f} | {x["floor_us"]:.0f} | '
                         f'{x["ratio"]:.2f}x | {x["paced_kernel_us"]:.0f} | '
                         f'{x["bare_floor_us"]:.0f} + {n["kernel_us"]:.0f} | '
                         f'{x["warm_ratio"]:.2f}x |')
        lines += ['', f'Node / floor: median {n["ratio"]:.2f}x (rounds '
                  f'{min(n["ratios"]):.2f}-{max(n["ratios"]):.2f}x). Latency p99 per 1 s '
                  f'window ({len(lat)} windows, the node alone): median '
                  f'{np.median(lat) if lat else float("nan"):.0f} us, worst '
                  f'{max(lat) if lat else float("nan"):.0f} us, '
                  f'{sum(v > STEP_US for v in lat)} over one step ({STEP_US:.0f} us); '
                  f'the slowest single input {_worst(n.get("latency_max_windows"))} us. '
                  f'First /tf {n["start_s"]:.2f} s after start (warm), '
                  f'{results["cold_start_s"]:.2f} s cold, {results["after_warm_s"]:.2f} s after '
                  '`jacket_cloth warm` (the set-up).']
    if 'crowd' in results:
        lines += [''] + crowd_summary(results['crowd'])
    return '\n'.join(lines) + '\n'


def write(results: dict, out_dir: str) -> None:
    """Write speed.json, speed.md and the charts.

    :param results: what :func:`run` returned.
    :param out_dir: the folder the files go to.
    """
    with open(os.path.join(out_dir, 'speed.json'), 'w', encoding='utf-8') as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(out_dir, 'speed.md'), 'w', encoding='utf-8') as f:
        f.write(summary(results))
    if 'crowd' in results:
        crowd_chart(results['crowd'], os.path.join(out_dir, 'crowd.png'))
    if 'kernel' not in results or 'replay' not in results:
        return
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8))
    for it in sorted({r['iterations'] for r in results['kernel']}):
        rows = [r for r in results['kernel'] if r['iterations'] == it]
        a.plot([r['constraints'] for r in rows], [r['kernel_ns'] / 1e3 for r in rows], 'o-',
               label=f'kernel, {it} iterations')
        if all('limit_ns' in r for r in rows):
            a.plot([r['constraints'] for r in rows], [r['limit_ns'] / 1e3 for r in rows], 'x--',
                   label=f'C yardstick, {it} iterations')
    a.set_xscale('log')
    a.set_yscale('log')
    a.set_xlabel('constraints (grids 6x10 to 33x48)')
    a.set_ylabel('one step (us)')
    a.legend(fontsize=7)
    a.set_title('cloth step against the compiled limit', fontsize=9)
    rep = results['replay']
    b.plot([r['session_s'] for r in rep], [r['replay_s'] for r in rep], 'o-')
    b.set_xlabel('session length (s)')
    b.set_ylabel('replay time (s)')
    b.set_title('replay: time against session length', fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, 'speed.png'), dpi=100)
    plt.close(fig)


def _worst(windows):
    """Return the largest of a run's per-window figures, shown as whole us ('nan' if none)."""
    return f'{max(windows):.0f}' if windows else 'nan'


def _endurance(e):
    """Return the endurance part's lines: memory and input cost, first window to last."""
    w = e['windows']
    return ['', f'Endurance: {w[-1]["simulated_s"]:.0f} s simulated through the node callback '
            f'with recording on; RSS {w[0]["rss_mb"]:.1f} -> {w[-1]["rss_mb"]:.1f} MB (most '
            f'{max(x["rss_mb"] for x in w):.1f}); input median {w[0]["input_us_median"]:.0f} -> '
            f'{w[-1]["input_us_median"]:.0f} us; {e["inputs"]} JointState and {e["tf"]} /tf '
            f'recorded' + ('' if e.get('complete', True) else ', the file left without its end')
            + '.']
