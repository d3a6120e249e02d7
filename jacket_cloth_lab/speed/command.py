# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``python -m jacket_cloth_lab bench speed``: every part in turn, each with its host's steal."""

import argparse
import os
import tempfile
from typing import Callable

from jacket_cloth_ros.core.skeleton import load_shipped_character
from .. import host_probe
from ..crowd import crowd_bench
from .endurance import endurance
from .hops import hop_count
from .host import host_phases
from .kernel import GRIDS, ITERATIONS, Yardstick, kernel_vs_limit, limit_source
from .live import cold_start, node_vs_floor
from .markers import markers_cost
from .measure import Steal
from .per_input import input_vs_kernel
from .replay import replay_scaling
from .report import summary, write
from .stages import profiled
from .targets import targets


def run(quick: bool, out_dir: str, say: Callable[[str], None] = print,
        endurance_s: float | None = None, only: str | None = None) -> dict:
    """Run every part of ``bench speed``, write its files; return the figures.

    :param quick: whether the quick mode: short runs, two grids, no node against the floor,
        no start times, the crowd's quick part.
    :param out_dir: the folder the files go to.
    :param say: called with each part's title as it starts.
    :param endurance_s: simulated seconds of the endurance run; None: 10 quick, else 600.
    :param only: run this part only (e.g. ``crowd``); None: all.
    """
    skeleton = load_shipped_character()
    os.makedirs(out_dir, exist_ok=True)
    source = limit_source()
    yardstick = Yardstick(source) if source and not quick else None
    results = {'quick': quick, 'limit': source or 'not found (../shared/limit/cloth_ref.c)'}
    steal = results['steal_percent'] = {}
    probe = host_probe.build_probe() if only in (None, 'host', 'kernel') else None

    def section(key, title, measure):
        if only and key != only:
            return
        say(title)
        with Steal() as taken:
            results[key] = measure()
        steal[key] = taken.percent
    if probe:
        section('host', 'what the host\'s phases slow', lambda: host_phases(
            skeleton, probe, 30 if quick else 300, yardstick))
    section('kernel', 'kernel against the yardstick', lambda: kernel_vs_limit(
        skeleton, GRIDS[:2] if quick else GRIDS, (8,) if quick else ITERATIONS, yardstick,
        probe))
    section('profile', 'where one input\'s time goes (replay, node)', lambda: [
        profiled(skeleton, 5.0 if quick else 15.0, node=node) for node in (False, True)])
    section('hops', 'the package\'s calls from the JointState callback to the /tf publish',
            lambda: hop_count(skeleton))
    section('markers', 'what the jacket\'s markers add to the node', lambda: markers_cost(
        skeleton, 5.0 if quick else 15.0, 1 if quick else 3))
    section('input', 'pipeline per input', lambda: input_vs_kernel(
        skeleton, 2.0 if quick else 10.0, 1.0 if quick else 5.0))
    with tempfile.TemporaryDirectory() as tmp:
        section('replay', 'replay throughput by session length', lambda: replay_scaling(
            skeleton, (5.0, 10.0) if quick else (5.0, 15.0, 30.0, 60.0, 120.0), tmp))
        endurance_s = endurance_s or (10.0 if quick else 600.0)
        section('endurance', 'endurance', lambda: endurance(
            skeleton, endurance_s, tmp, window_s=5.0 if quick else 60.0))
        if not quick:
            section('node', 'live node against the floor node (120 Hz, recording on)',
                    lambda: node_vs_floor(skeleton, 10.0,
                                          results['input']['kernel_us_median'], tmp))
            section('cold_start_s', 'cold start', lambda: cold_start(skeleton))
            section('after_warm_s', 'start after jacket_cloth warm',
                    lambda: cold_start(skeleton, warmed=True))
        section('crowd', 'crowd node against one node process per character', lambda: crowd_bench(
            skeleton, quick, say=say))
    results['targets'] = targets(results)          # judged once: speed.md, speed.json
    write(results, out_dir)
    return results


def main(args: argparse.Namespace) -> int:
    """Run ``bench speed`` with the command's options and print its summary.

    :param args: the ``bench`` command's options (quick, out, endurance, only).
    :returns: the exit status.
    """
    results = run(args.quick, args.out, say=lambda t: print(t, flush=True),
                  endurance_s=args.endurance, only=args.only)
    print(summary(results))
    return 0
