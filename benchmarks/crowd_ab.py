# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Drive a live crowd node from two source trees, alternately, and compare them.

    python benchmarks/crowd_ab.py OLD_TREE NEW_TREE [--characters 64] [--rounds 3]
                                  [--seconds 4] [--cores 0]

Each round runs one jacket_cloth_crowd process per tree (in alternating order) through the
lab's live driver (``jacket_cloth_lab.crowd.live``: one 120 Hz JointState stream every
character hears, the crowd pinned to ``--cores``, the driver to the others) and keeps its CPU
per character-input, its worst 1 s window of latency p99 and the share of inputs answered.
Prints each run and the medians. Both trees must have their kernels compiled (start a crowd
or a replay in each first). Run it alone: a rung's latency spreads by milliseconds from one
run to the next (docs/crowd.md), so read medians over rounds, not one run.
"""

import argparse
import os
import statistics
import sys
import tempfile


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('old')
    parser.add_argument('new')
    parser.add_argument('--characters', type=int, default=64)
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--seconds', type=float, default=4.0)
    parser.add_argument('--cores', default='0', help='the crowd\'s cores, e.g. 0 or 0,1')
    args = parser.parse_args()
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    from jacket_cloth_lab.crowd import crowd_command, live
    from jacket_cloth_ros.core.skeleton import Skeleton, shipped_character_urdf
    skeleton = Skeleton(shipped_character_urdf())
    cores = {int(c) for c in args.cores.split(',')}
    runs = {'old': [], 'new': []}
    with tempfile.TemporaryDirectory() as folder:       # the characters files (URDF shipped)
        for r in range(args.rounds):
            for name in (('old', 'new') if r % 2 == 0 else ('new', 'old')):
                tree = os.path.abspath(getattr(args, name))
                os.environ['PYTHONPATH'] = tree
                os.chdir(tree)          # python -m puts the working folder first
                got = live(skeleton, [crowd_command(args.characters, folder, len(cores))],
                           args.characters, args.seconds, 30 + os.getpid() % 20, cores)
                runs[name].append(got)
                print(f'{name} round {r + 1}: CPU {got["cpu_us"]:.0f} us per character-input, '
                      f'latency p99 worst window {got["latency_us_p99"] / 1e3:.2f} ms, '
                      f'answered {got["answered"]:.2f}, held {got["held"]}', flush=True)
    medians = {}
    for name, got in runs.items():
        medians[name] = [statistics.median(g[k] for g in got)
                         for k in ('cpu_us', 'latency_us_p99')]
        print(f'{name}: CPU median {medians[name][0]:.0f} us, latency p99 worst window median '
              f'{medians[name][1] / 1e3:.2f} ms, held {sum(g["held"] for g in got)} of '
              f'{len(got)}')
    print(f'new / old: CPU {medians["new"][0] / medians["old"][0]:.3f}x, latency '
          f'{medians["new"][1] / medians["old"][1]:.3f}x')
    return 0


if __name__ == '__main__':
    sys.exit(main())
