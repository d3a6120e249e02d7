# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s targets (issue 37), each a ratio within one run, judged from its results."""

from ..profile import MAIN_THREAD_AT_LEAST, main_thread_share
from .hops import FILES_AT_MOST, HOPS_AT_MOST
from .kernel import KERNEL_TARGET
from .markers import MARKERS_AT_MOST
from .measure import STEP_US
from .replay import replay_of_limit

# The replay's share of its kernel-only limit, by the shortest session it applies to: a short
# session also pays the set-up once.
REPLAY_TARGETS = ((5.0, 0.5), (15.0, 0.8))
NODE_OVER_FLOOR = 1.2
COST_ONLY = 'none'                 # a figure in the targets' table that has no target


def targets(results: dict) -> list[dict]:
    """Return the speed targets as this run measured them.

    :param results: what :func:`run` returned (any part may be missing).
    :returns: one dict per target: ``figure``, ``measured`` (text), ``target`` (text) and
        ``met`` (True, False, or None where the run did not measure it).
    """
    rows = []
    if 'replay' in results:
        shares = list(zip((r['session_s'] for r in results['replay']), replay_of_limit(results)))
        for k, (shortest, at_least) in enumerate(REPLAY_TARGETS):
            longest = REPLAY_TARGETS[k + 1][0] if k + 1 < len(REPLAY_TARGETS) else float('inf')
            got = [(s, x) for s, x in shares if shortest <= s < longest]
            said = ', '.join(f'{x:.2f} ({s:g} s)' for s, x in got) or 'no such session'
            rows.append({'figure': f'replay / kernel-only limit, sessions of {shortest:g} s'
                         + (f' to under {longest:g} s' if longest < float('inf') else ' and more'),
                         'measured': said, 'target': f'≥ {at_least:g}',
                         'met': min(x for _, x in got) >= at_least if got else None})
    if 'node' in results:
        n = results['node']
        lat = n['latency_windows']
        over = sum(v > STEP_US for v in lat)
        rows.append({'figure': f'live node CPU per JointState / floor with its kernel, median '
                     f'of {len(n["ratios"])} rounds', 'measured': f'{n["ratio"]:.2f}x (rounds '
                     f'{min(n["ratios"]):.2f}–{max(n["ratios"]):.2f}x)',
                     'target': f'≤ {NODE_OVER_FLOOR:g}x', 'met': n['ratio'] <= NODE_OVER_FLOOR})
        slowest = n.get('latency_max_windows') or []      # not in runs from before it was
        rows.append({'figure': 'latency p99, arrival to /tf, per 1 s window',
                     'measured': (f'{over} of {len(lat)} windows over a step, worst '
                                  f'{max(lat) / 1e3:.1f} ms' + (
                                      f'; the slowest input {max(slowest) / 1e3:.1f} ms'
                                      if slowest else '')) if lat else 'no window',
                     'target': f'none over one step ({STEP_US / 1e3:.1f} ms)',
                     'met': not over if lat else None})
    for p in results.get('profile', ()):
        share = main_thread_share(p)
        if share is None:
            continue                # a speed.json from before the untimed pass
        at_least = MAIN_THREAD_AT_LEAST[p['node']]
        which = ("the node's main thread per 60 Hz input less rclpy's take and publish"
                 if p['node'] else "the replay's main thread per 60 Hz input")
        rows.append({'figure': f'{which} (the profile\'s walk, no stage timers), over the '
                     'kernel-only limit timed beside it',
                     'measured': f'{share[0]:.2f} ({share[1]:.0f} us of limit, {share[2]:.0f} '
                     'us taken)', 'target': f'≥ {at_least:g}', 'met': share[0] >= at_least})
    if 'hops' in results:
        h = results['hops']
        rows.append({'figure': 'from the JointState callback to the /tf publish: the deepest '
                     'chain of the package\'s calls, and the modules they ran in',
                     'measured': f'{h["hops"]} functions in {len(h["files"])} files '
                     f'({h["functions"]} functions ran)',
                     'target': f'≤ {HOPS_AT_MOST} functions in ≤ {FILES_AT_MOST} files',
                     'met': h['hops'] <= HOPS_AT_MOST and len(h['files']) <= FILES_AT_MOST})
    if 'markers' in results:
        for kind, what, target in (
                ('live', 'at the node\'s defaults (a viewer\'s markers, nothing recorded)', True),
                ('recorded', 'with the session recorded (the markers recorded too)', False)):
            m = results['markers'].get(kind)
            if not m or 'share' not in m:
                continue                # a speed.json from before these figures
            added = [r['added'] for r in m['rounds']]
            shares = [r['share'] for r in m['rounds']]
            if target and 'skinning' in m:
                skins = [r['skinning'] for r in m['rounds']]
                rows.append({'figure': f'the jacket\'s skinning at the markers\' rate added to '
                             f'the node\'s CPU per input {what}: skinned, shaded and laid out '
                             f'into the message, over the rest of the same run, median of '
                             f'{len(skins)} rounds',
                             'measured': f'{m["skinning"]:+.1%} (rounds {min(skins):+.1%} to '
                             f'{max(skins):+.1%}; {m["skinning_us"]:.0f} us per input)',
                             'target': f'≤ {MARKERS_AT_MOST:.0%}',
                             'met': m['skinning'] <= MARKERS_AT_MOST})
            rows.append({'figure': f'the jacket\'s markers added to the node\'s CPU per input '
                         f'{what}: their stage and publishing over the rest of the same run, '
                         f'median of {len(added)} rounds',
                         'measured': f'{m["share"]:+.1%} (rounds {min(shares):+.1%} to '
                         f'{max(shares):+.1%}); run with over run without {m["added"]:+.1%} '
                         f'({m["without_us"]:.0f} -> {m["with_us"]:.0f} us; rounds '
                         f'{min(added):+.1%} to {max(added):+.1%})' + ''.join(
                             f'; at {float(rate):g} Hz {share:+.1%}'
                             for rate, share in m.get('share_by_rate', {}).items()),
                         'target': (f'≤ {MARKERS_AT_MOST:.0%} (the whole markers, a stricter '
                                    f'reading)') if target else COST_ONLY,
                         'met': m['share'] <= MARKERS_AT_MOST if target else None})
    cell = [r for r in results.get('kernel', ()) if r['grid'] == KERNEL_TARGET['grid']
            and r['iterations'] == KERNEL_TARGET['iterations']]
    if cell:
        rows.append(_kernel_target(cell[0]))
    return rows


def _kernel_target(r: dict) -> dict:
    """Return item 4's row: the median of the rounds on a quiet host, where a probe sorted them.

    :param r: the kernel part's row at the target's grid and sweeps (:func:`in_rounds`).
    """
    runs = r.get('ratios', [r['ratio']] if 'ratio' in r else [])
    quiet = r.get('quiet')
    counted = [x for x, q in zip(runs, quiet) if q] if quiet else runs
    enough = len(counted) >= KERNEL_TARGET['fewest_rounds']
    said = (f'{r["ratio"]:.2f}x (rounds {min(counted):.2f}–{max(counted):.2f}x)'
            if len(counted) > 1 else f'{r["ratio"]:.2f}x' if counted
            else 'no round on a quiet host' if runs else 'no yardstick beside this checkout')
    if quiet is not None:
        slow = [ns / y for ns, y in zip(r['slow_kernel_ns'], r['limit_rounds_ns']) if ns]
        said += (f'; {sum(r["quiet_passes"])} of {sum(r["passes"])} passes with the probe '
                 'quiet' + (f', the passes not counted {min(slow):.2f}–{max(slow):.2f}x'
                            if slow else ''))
    which = (f'rounds timed on a quiet host (of {len(runs)})' if quiet is not None
             else 'rounds')
    return {'figure': f'kernel / C yardstick, {r["grid"]} at {r["iterations"]} sweeps, '
            f'median of {len(counted)} {which}',
            'measured': said if enough or not runs else said + ', too few rounds',
            'target': f'≤ {KERNEL_TARGET["at_most"]:g}x',
            'met': r['ratio'] <= KERNEL_TARGET['at_most'] if enough else None}
