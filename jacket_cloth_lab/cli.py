# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``python -m jacket_cloth_lab``: the lab's benchmarks, apart from the product's command.

Every failure ends in one readable line on stderr and a non-zero exit, never a traceback.
"""

import argparse
import os
import sys
from typing import Sequence

from jacket_cloth_ros.core.config import ConfigError
from .tables import add_parser as add_tables_parser, write_run

PROG = 'python -m jacket_cloth_lab'


class LabError(Exception):
    """A failure to report in one line."""


def cmd_stress(args: argparse.Namespace) -> int:
    """Run the stress scenes for the methods asked; write stress.md and say what failed.

    :param args: the ``stress`` command's options.
    :returns: the exit status.
    """
    from .stress import METHODS, XPBD_METHODS, stress, write_cloth, write_matrix
    methods = tuple(args.methods.split(',')) if args.methods else METHODS + XPBD_METHODS
    known = METHODS + XPBD_METHODS
    unknown = [m for m in methods if m not in known]
    if unknown:
        raise LabError(f'unknown method(s) {", ".join(unknown)} (methods: {", ".join(known)})')
    loop = 3600.0 if args.full else args.loop
    end_frames, pictured = {}, 'hard_pass' if 'hard_pass' in methods else methods[0]
    results = stress(methods, loop_s=loop, end_frames=end_frames, pictured=pictured)
    write_matrix(results, args.out, methods)
    write_cloth(results, end_frames, pictured, args.out)
    failed = sorted({s for (s, m), (v, _) in results.items() if v != 'holds'})
    print(f'{os.path.join(args.out, "stress.md")}: {len(results)} runs, '
          f'{sum(v == "holds" for v, _ in results.values())} hold'
          + (f'; failures in: {", ".join(failed)}' if failed else ''))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    """Run a benchmark (accuracy, speed or lod); write its files and say its headline figure.

    :param args: the ``bench`` command's options.
    :returns: the exit status.
    """
    folders = {'speed': 'out/bench_speed', 'lod': 'out/bench_lod'}
    # One part of bench speed goes beside the whole run's files, not over them.
    part = f'_{args.only}' if args.what == 'speed' and args.only else ''
    args.out = args.out or folders.get(args.what, 'out/bench') + part
    if args.what == 'speed':
        from .speed import main as speed_main
        return speed_main(args)
    if args.what == 'lod':
        from .lod import lod_bench, write as write_lod
        results = lod_bench(seconds=args.seconds or (1.0 if args.quick else 3.0),
                            repeats=1 if args.quick else 3)
        write_lod(results, args.out)
        far = results['rows'][-1]
        print(f'{os.path.join(args.out, "lod.md")}: at {far["distance_m"]:g} m, '
              f'{far["cost_vs_full"]:.2f}x the full-detail cost', flush=True)
        from .lod import crowd_lod_bench, write_crowd
        crowd = crowd_lod_bench(crowds=(4, 16) if args.quick else (4, 16, 64),
                                seconds=0.5 if args.quick else 2.0,
                                repeats=1 if args.quick else 3)
        write_crowd(crowd, args.out)
        big = crowd['rows'][-1]
        print(f'{os.path.join(args.out, "crowd_lod.md")}: {big["characters"]} characters '
              f'spread to {crowd["spread_m"]:g} m, LOD on {big["on_vs_off"]:.2f}x the cost of '
              'LOD off')
        return 0
    from .bench import CLIPS, bench, write
    clips = tuple(args.clips.split(',')) if args.clips else (('walk',) if args.quick else CLIPS)
    unknown = [c for c in clips if c not in CLIPS]
    if unknown:
        raise LabError(f'unknown clip(s) {", ".join(unknown)} (clips: {", ".join(CLIPS)})')
    seconds = args.seconds or (1.0 if args.quick else 3.0)
    results = bench(clips, quick=args.quick, seconds=seconds,
                    progress=lambda text: print(text, flush=True))
    write(results, args.out)
    default = [r for c in results['clips'].values() for r in c['rows']
               if r['label'] == results['default']]
    print(f'{os.path.join(args.out, "bench.md")}: {len(clips)} clip(s); the default\'s hem '
          f'error RMS {max(r["hem_rms_m"] for r in default) * 1e3:.1f} mm at worst, '
          f'{max(r["cost_ms_per_s"] for r in default):.0f} ms per simulated s')
    return 0


def cmd_tables(args: argparse.Namespace) -> int:
    """Rewrite the docs' figure tables from the benches' results.

    :param args: the ``tables`` command's options.
    :returns: the exit status: 1 if checking and a table would change.
    """
    from .tables import run_tables
    if not os.path.isdir(args.docs):
        raise LabError(f'{args.docs}: no such folder')
    return run_tables(args.docs, args.results, args.check)


def build_parser() -> argparse.ArgumentParser:
    """Return the lab's command line: ``stress``, ``bench`` and ``tables``."""
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest='command', required=True)
    st = sub.add_parser('stress', help='the scenes where methods fail, for every method')
    st.add_argument('--out', default='out/stress',
                    help="folder for stress.md/.json/.png and the scenes' pictures")
    st.add_argument('--methods', default=None,
                    help='comma-separated stretch limits, xpbd+<limit> for XPBD (default: all)')
    st.add_argument('--loop', type=float, default=60.0, help='s of looped walk (quick mode)')
    st.add_argument('--full', action='store_true', help='an hour of looped walk')
    st.set_defaults(func=cmd_stress)
    b = sub.add_parser('bench', help='accuracy against measured cost per clip (or: bench speed)')
    b.add_argument('what', nargs='?', default='accuracy', choices=('accuracy', 'speed', 'lod'),
                   help='accuracy: the Pareto sweep (default); speed: ratios to the limit; '
                   'lod: cost and error against viewer distance')
    b.add_argument('--out', default=None, help='output folder (default: out/bench[_speed])')
    b.add_argument('--quick', action='store_true', help='a few methods on one short clip')
    b.add_argument('--clips', default=None, help='comma-separated motion clips')
    b.add_argument('--seconds', type=float, default=None, help='length of each clip')
    b.add_argument('--endurance', type=float, default=None,
                   help='speed: simulated s through the node (default 600; 3600 for the hour)')
    b.add_argument('--only', default=None,
                   choices=('host', 'kernel', 'profile', 'hops', 'markers', 'endurance',
                            'crowd'),
                   help='speed: run this part only (host: what the host\'s phases slow; '
                   'kernel: against the yardstick; profile: one input\'s stages against '
                   'the kernel-only limit; hops: the package\'s calls from the JointState '
                   'callback to the /tf publish; markers: what the jacket\'s markers add to '
                   'the node; endurance: --endurance s through the node\'s callback, '
                   'recording; crowd)')
    b.set_defaults(func=cmd_bench)
    add_tables_parser(sub).set_defaults(func=cmd_tables)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the lab's command; a failure is one line on stderr and exit 1.

    :param argv: the arguments; None: the process's.
    :returns: the exit status.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    try:
        status = args.func(args)
        if status == 0 and args.command in ('bench', 'stress'):
            write_run(args.out, argv)      # the docs' tables say which run their figures are
        return status
    except (LabError, ConfigError, ValueError, OSError) as e:
        print(f'{PROG} {args.command}: {e}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
