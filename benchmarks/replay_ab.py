# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Replay one recording with two source trees, alternately, and print their CPU as a ratio.

    python benchmarks/replay_ab.py OLD_TREE NEW_TREE RECORDING [--rounds 7]

Each round starts one replay process per tree (in alternating order), each process's CPU time
(user + system, from wait4) and the replay's own wall time are kept, and the medians are
compared. Both trees must have their kernels compiled (run one replay in each first). A shared
machine's single processes spread by several percent: read ratios, over many rounds.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile


def replay_once(tree: str, recording: str, out: str) -> tuple[float, float]:
    """Replay ``recording`` with the package in ``tree``; return (CPU s, replay wall s)."""
    env = dict(os.environ, PYTHONPATH=tree)
    proc = subprocess.Popen([sys.executable, '-m', 'jacket_cloth_ros', 'replay', recording,
                             '-o', out, '--force'], cwd=tree, env=env, stdout=subprocess.PIPE,
                            text=True)
    printed = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    if status:
        raise SystemExit(f'replay_ab: the replay in {tree} failed')
    return usage.ru_utime + usage.ru_stime, float(printed.split(' in ')[1].split(' s')[0])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('old')
    parser.add_argument('new')
    parser.add_argument('recording')
    parser.add_argument('--rounds', type=int, default=7)
    args = parser.parse_args()
    figures = {'old': [], 'new': []}
    with tempfile.TemporaryDirectory() as folder:
        for r in range(args.rounds):
            order = ('old', 'new') if r % 2 == 0 else ('new', 'old')
            for name in order:
                tree = os.path.abspath(getattr(args, name))
                figures[name].append(replay_once(tree, os.path.abspath(args.recording),
                                                 os.path.join(folder, f'{name}.mcap')))
    for name, runs in figures.items():
        print(f'{name}: CPU median {statistics.median(c for c, _ in runs):.3f} s, replay '
              f'median {statistics.median(w for _, w in runs):.3f} s ({len(runs)} runs)')
    cpu = [statistics.median(c for c, _ in figures[n]) for n in ('old', 'new')]
    wall = [statistics.median(w for _, w in figures[n]) for n in ('old', 'new')]
    print(f'new / old: CPU {cpu[1] / cpu[0]:.3f}x, replay {wall[1] / wall[0]:.3f}x')
    return 0


if __name__ == '__main__':
    sys.exit(main())
