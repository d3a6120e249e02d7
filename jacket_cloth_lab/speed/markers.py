# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``bench speed``'s markers part: what the jacket's markers add to the node's CPU per input."""

import numpy as np

from jacket_cloth_ros.core.skeleton import Skeleton
from .. import profile

LOWER_MARKERS_RATES = (20.0, 15.0)     # every third and fourth 60 Hz input, against 30 Hz
MARKERS_AT_MOST = 0.10             # what the jacket's markers may add to the node's CPU per input


def markers_cost(skeleton: Skeleton, seconds: float, rounds: int = 3) -> dict:
    """Measure what the jacket's markers add to the node's whole CPU per input.

    The profiled node path (:func:`profile.per_input_profile`, rclpy take and publish) runs
    with the default markers (the skinned jacket and the body's pieces at ``markers_rate``)
    and with ``markers_rate`` 0, alternately, a few rounds: at the node's defaults (``live``:
    nothing recorded), and with the session recorded (``recorded``: the recorder's writer
    thread, which compresses the markers, counted too).

    Two figures per round. ``added``: the run with markers over the run without. This host's
    speed changes in phases of seconds, as long as a run, so a pair of runs can differ by
    more than the markers cost, either way. ``share``: within the run with markers, what their
    own stage and their publishing cost over the rest of that run, which one phase reaches
    alike; it misses what the markers cost other stages (their caches), which ``added``
    includes. ``share_by_rate`` (live): the share at lower ``markers_rate`` settings
    (:data:`LOWER_MARKERS_RATES`), what a steppier viewer would save. ``skinning``: the same
    for the jacket's skinning alone (skinned, shaded and laid
    out into the message, Outfit.draw_jacket), what the issue's target names.

    :param skeleton: the shipped character.
    :param seconds: the walk's length of each run.
    :param rounds: how many pairs of runs of each.
    :returns: ``{'live': cost, 'recorded': cost}``, each ``{'rounds': [{'with_us',
        'without_us', 'markers_stage_us', 'skinning_us', 'added', 'share', 'skinning'}],
        'added', 'share', 'skinning' (each the median round's), 'with_us', 'without_us'}``,
        and in ``live`` ``share_by_rate``: {markers_rate: median share}.
    """
    runs = {'live': [], 'recorded': []}
    by_rate = {rate: [] for rate in LOWER_MARKERS_RATES}
    for _ in range(rounds):
        for rate, shares in by_rate.items():
            p = profile.per_input_profile(skeleton, seconds, node=True, record=False,
                                          overrides={'markers_rate': rate})
            own = p['us']['markers'] + p['markers_publish_us']
            shares.append(own / (p['us_per_input'] + p['writer_thread_us'] - own))
        for kind, record in (('live', False), ('recorded', True)):
            cost = {}
            for key, overrides in (('with', {}), ('without', {'markers_rate': 0.0})):
                p = profile.per_input_profile(skeleton, seconds, node=True,
                                              overrides=overrides, record=record)
                cost[key] = p['us_per_input'] + p['writer_thread_us']
                if key == 'with':
                    stage = p['us']['markers']
                    own = stage + p['markers_publish_us']
                    skinning = p['markers_skinning_us']
            runs[kind].append({'with_us': cost['with'], 'without_us': cost['without'],
                               'markers_stage_us': stage, 'skinning_us': skinning,
                               'added': cost['with'] / cost['without'] - 1.0,
                               'share': own / (cost['with'] - own),
                               'skinning': skinning / (cost['with'] - skinning)})
    out = {}
    for kind, each in runs.items():
        middle = sorted(each, key=lambda r: r['added'])[len(each) // 2]
        out[kind] = dict(middle, rounds=each,
                         share=float(np.median([r['share'] for r in each])),
                         skinning=float(np.median([r['skinning'] for r in each])))
    out['live']['share_by_rate'] = {rate: float(np.median(shares))
                                    for rate, shares in by_rate.items()}
    return out
