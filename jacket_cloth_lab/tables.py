# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``python -m jacket_cloth_lab tables``: the docs' figure tables, written from the lab's results.

A table of measured figures in ``docs/`` sits in a marked region::

    <!-- lab: lod.latest -->
    (written by this command)
    <!-- /lab -->

Each kind of region (:data:`TABLES`) names the JSON files it is rendered from, under ``--from``
(default ``out/``), and one renderer. The region is headed by the command that wrote those
files and the day it ran (``run.json``, which the lab's commands write beside their results;
the file's own date and the documented command for the product's ``analyze``). A region
whose results are not there keeps its text.
"""

import argparse
import datetime
import json
import os
import re
import shlex
from dataclasses import dataclass
from typing import Any, Callable, Sequence

from . import host_probe, profile

PROG = 'python -m jacket_cloth_lab'
REGION = re.compile(r'(<!-- lab: (?P<kind>[\w.]+) -->\n)(?P<body>.*?)(<!-- /lab -->)', re.S)
RUN_FILE = 'run.json'


class Missing(Exception):
    """The results lack a part the table needs (a bench run with ``--only``, say)."""


Render = Callable[[Sequence[Any]], list[str]]


@dataclass(frozen=True)
class Table:
    """A kind of region: the results it is rendered from and how.

    :param sources: JSON files under the results folder, each one run's.
    :param commands: the command that writes each source, said when it left no run.json.
    :param render: markdown lines from the loaded sources, in order.
    """

    sources: tuple[str, ...]
    commands: tuple[str, ...]
    render: Render


def write_run(out_dir: str, argv: Sequence[str]) -> None:
    """Write ``run.json`` beside a command's results: the command and the day it finished.

    :param out_dir: the folder the command wrote its results to.
    :param argv: the command's arguments after ``python -m jacket_cloth_lab``.
    """
    stamp = {'command': f'{PROG} {shlex.join(argv)}',
             'date': datetime.datetime.now(datetime.timezone.utc).date().isoformat()}
    with open(os.path.join(out_dir, RUN_FILE), 'w', encoding='utf-8') as f:
        json.dump(stamp, f, indent=1)


def run_of(path: str, command: str) -> tuple[str, str]:
    """Return (command, date) of the run that wrote a results file.

    :param path: the results file.
    :param command: the command to say when no ``run.json`` sits beside it.
    """
    stamp = os.path.join(os.path.dirname(path), RUN_FILE)
    if os.path.isfile(stamp):
        with open(stamp, encoding='utf-8') as f:
            run = json.load(f)
        return run['command'], run['date']
    mtime = datetime.datetime.fromtimestamp(os.path.getmtime(path), datetime.timezone.utc)
    return command, mtime.date().isoformat()


# -- renderers: one per kind of table ------------------------------------------------------------

def _table(head: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    return (['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
            + ['| ' + ' | '.join(row) + ' |' for row in rows])


def _span(values: Sequence[float], form: str = '.2f', unit: str = '') -> str:
    low, high = min(values), max(values)
    if f'{low:{form}}' == f'{high:{form}}':
        return f'{low:{form}}{unit}'
    return f'{low:{form}}–{high:{form}}{unit}'


def _part(results: dict, key: str) -> Any:
    if key not in results:
        raise Missing(f'no {key!r} part')
    return results[key]


def speed_latest(sources: Sequence[Any]) -> list[str]:
    """Return the speed bench's headline figures, each as measured within its run.

    The figures ``bench speed`` judges against its targets come first, without the verdicts:
    those are the bench's own output (speed.md), the docs say what a figure means.

    :param sources: speed.json.
    :returns: the table's lines and a line of the CPU steal each part saw.
    """
    s = sources[0]
    kernel, replay, pipe = _part(s, 'kernel'), _part(s, 'replay'), _part(s, 'input')
    rows = [[t['figure'], t['measured']] for t in _part(s, 'targets')]
    ref = [k for k in kernel if k['grid'] == '9x12' and k['iterations'] == 8 and 'limit_ns' in k]
    per_step = [r['replay_s'] / (r['session_s'] * 120.0) * 1e6 for r in replay]
    said = _span([r['realtime_x'] for r in replay], '.0f', 'x')
    if ref:
        limit_us = ref[0]['limit_ns'] / 1e3
        said += (f'; per 120 Hz step {_span([p / limit_us for p in per_step])}x the '
                 f'yardstick\'s {limit_us:.1f} µs')
    lengths = '/'.join(f'{r["session_s"]:g}' for r in replay)
    rows.append([f'replay, x real time, {lengths} s sessions', said])
    if 'cold_start_s' in s:
        warm = s['node']['start_s']
        rows.append(['first `/tf` after start', f'{s["cold_start_s"]:.2f} s with an empty cache, '
                     f'{s["after_warm_s"]:.2f} s after `jacket_cloth warm`, {warm:.2f} s warm'])
    grids = '/'.join(dict.fromkeys(k['grid'] for k in kernel))
    sweeps = '/'.join(str(i) for i in dict.fromkeys(k['iterations'] for k in kernel))
    ratios = [k['ratio'] for k in kernel if 'ratio' in k]
    rows.append([f'kernel / yardstick, {grids} grids, {sweeps} sweeps',
                 f'{_span(ratios)}x' if ratios else 'no yardstick beside this checkout'])
    rows.append(['pipeline per JointState / kernel', f'{pipe["ratio"]:.1f}x back to back '
                 f'({pipe["input_us_median"]:.0f} / {pipe["kernel_us_median"]:.0f} µs); '
                 f'{pipe["paced_ratio"]:.1f}x paced at 120 Hz'])
    e = _part(s, 'endurance')
    w = e['windows']
    rows.append([f'{w[-1]["simulated_s"]:.0f} s through the node, recording on',
                 f'{e["inputs"]} in = {e["tf"]} `/tf`; resident memory {w[0]["rss_mb"]:.1f} → '
                 f'{w[-1]["rss_mb"]:.1f} MB; input median per window '
                 f'{_span([x["input_us_median"] for x in w], ".0f")} µs'])
    steal = ', '.join(f'{k} {v:.0f} %' for k, v in s.get('steal_percent', {}).items())
    return _table(('figure', 'measured'), rows) + (
        ['', f'CPU steal while each part ran: {steal}.'] if steal else [])


def speed_profile(sources: Sequence[Any]) -> list[str]:
    """Return where one input's CPU goes, by stage, on the replay's and the node's path.

    :param sources: speed.json.
    :returns: the table's lines, a line on the recorder's thread and the sweeps, and one
        setting the stages against the kernel-only limit timed beside them.
    """
    return profile.summary(_part(sources[0], 'profile'))


def speed_host(sources: Sequence[Any]) -> list[str]:
    """Return what the host slows with the kernel, measure by measure.

    :param sources: speed.json.
    """
    return host_probe.summary(_part(sources[0], 'host'))


def lod_latest(sources: Sequence[Any]) -> list[str]:
    """Return the level of detail's cost and error against the viewer's distance.

    :param sources: lod.json.
    """
    s = sources[0]
    rows = [['none' if r['distance_m'] is None else f'{r["distance_m"]:g}', str(r['level']),
             f'{r["cost_vs_full"]:.2f}', f'{r["cloth_rms_m"] * 100:.2f}',
             f'{r["cloth_max_m"] * 100:.2f}'] for r in s['rows']]
    levels = ', '.join(f'{d:g}' for d in s['lod_distances'])
    return [f'{s["clip"]}, {s["seconds"]:g} s, `lod_distances` [{levels}]:', ''] + \
        _table(('viewer at m', 'level', 'cost vs full', 'cloth RMS vs full cm', 'max cm'), rows)


def crowd_lod(sources: Sequence[Any]) -> list[str]:
    """Return a crowd's CPU per character-input with the level of detail on and off.

    :param sources: crowd_lod.json.
    """
    s = sources[0]
    rows = [[str(r['characters']), f'{r["us_per_character_off"]:.0f}',
             f'{r["us_per_character_on"]:.0f}', f'{r["on_vs_off"]:.2f}',
             ' / '.join(str(v) for v in r['inputs_per_level'])] for r in s['rows']]
    return _table(('characters', 'LOD off µs', 'LOD on µs', 'on / off',
                   'inputs at level 0 / 1 / 2'), rows)


def _rung(row: dict) -> str:
    if 'not_answering' in row:
        return f'{row["characters"]} (not all answered)'
    return (f'{row["characters"]} ({row["cpu_us"]:.0f} µs per character-input, p99 '
            f'{row["latency_us_p99"] / 1e3:.1f} ms)')


def _ladder(name: str, ladder: list, one_core: int | None = None) -> list[str]:
    best, rows = ladder
    held = [r for r in rows if r['characters'] == best]
    failed = [r for r in rows if not r['held']]
    said = _rung(held[0]) if held else str(best)
    if one_core:
        said = f'{best} ({best / one_core:.2f}x one core)'
    return [name, said, _rung(failed[0]) if failed else 'none up to the ladder\'s top']


def crowd_held(sources: Sequence[Any]) -> list[str]:
    """Return a crowd node's cost per character against N, and the most characters held.

    :param sources: speed.json, its crowd part.
    """
    c = _part(sources[0], 'crowd')
    single, cost = c['single_cost'][0], c['cost']

    def each(value: Callable[[dict], float], form: str = '.0f') -> str:
        return '/'.join(f'{value(r):{form}}' for r in cost)
    lines = [f'CPU per character-input at {each(lambda r: r["characters"], "d")} characters: '
             f'{each(lambda r: r["cpu_us"])} µs, '
             f'{each(lambda r: r["cpu_us"] / single["cpu_us"], ".2f")}x a single node\'s '
             f'({single["cpu_us"]:.0f} µs). Resident memory of the crowd process: '
             f'{each(lambda r: r["rss_mb_per_character"] * r["characters"])} MB; of a single '
             f'node {single["rss_mb_per_character"]:.0f} MB.']
    if 'crowd_one_core' not in c:
        return lines + ['', 'The ladders of characters held run in the full mode only.']
    one = c['crowd_one_core'][0]
    held = [_ladder('crowd, one core', c['crowd_one_core']),
            _ladder('its floor, one core', c['floor_one_core']),
            _ladder(f'crowd, {c["cores"]} threads', c['crowd_all_cores'], one),
            _ladder('one crowd process per core', c['crowd_per_core'], one),
            ['single-node processes, one core / all',
             f'{c["single_one_core"][0]} / {c["single_all_cores"][0]}',
             ' / '.join(_first_not_held(c[k]) for k in ('single_one_core', 'single_all_cores'))]]
    return _table(('', 'held', 'the first count not held'), held) + [''] + lines


def _first_not_held(ladder: list) -> str:
    failed = [r['characters'] for r in ladder[1] if not r['held']]
    return str(failed[0]) if failed else '-'


def _row_of(clip: dict, label: str) -> dict:
    for row in clip['rows']:
        if row['label'] == label:
            return row
    raise Missing(f'no {label!r} row')


def _mm(value: float) -> str:
    return f'{value * 1e3:.1f}'


def bench_references(sources: Sequence[Any]) -> list[str]:
    """Return per clip the two references apart, and the default's and its rivals' hem error.

    Each rival's cost is against the default's, the two timed in turns (``head_to_head``).

    :param sources: bench.json.
    """
    s = sources[0]
    rows, rivals, rounds = [], [], 0
    for clip, data in s['clips'].items():
        apart, check = data['references_apart'], data['gs_richardson']
        turns = data['head_to_head']
        rivals = [label for label in turns['vs_first'] if label != s['default']]
        rounds = turns['rounds']
        default = _row_of(data, s['default'])
        row = [clip, f'{apart["cloth_rms_m"] * 100:.2f} / {apart["cloth_max_m"] * 100:.2f}',
               f'{apart["hem_rms_m"] * 100:.2f} / {apart["hem_max_m"] * 100:.2f}',
               _mm(check['cloth_rms_m']),
               f'{_mm(default["hem_rms_m"])} / {_mm(default["vs_gs"]["hem_rms_m"])}']
        for label in rivals:
            peer = _row_of(data, label)
            row.append(f'{_mm(peer["hem_rms_m"])} / {_mm(peer["vs_gs"]["hem_rms_m"])}; '
                       f'{turns["vs_first"][label]:.2f}x')
        rows.append(row)
    return [f'Clips of {s["clip_seconds"]:g} s; references {s["reference"]} and '
            f'{s["gs_reference"]}; each rival\'s cost over the default\'s is the median of '
            f'{rounds} rounds run in turns:', ''] + _table((
                'clip', 'references apart: every vertex RMS / max (cm)', 'hem RMS / max (cm)',
                'GS reference vs its finer run, every vertex RMS (mm)',
                f'default ({s["default"]}) hem RMS vs XPBD / GS ref (mm)',
                *(f'{label}: the same; cost / the default\'s' for label in rivals)), rows)


def bench_pareto(sources: Sequence[Any]) -> list[str]:
    """Return per clip where the default sits against the Pareto front of each reference.

    :param sources: bench.json.
    """
    s = sources[0]
    rows = []
    for clip, data in s['clips'].items():
        default = _row_of(data, s['default'])
        fixed = [r for r in data['rows'] if not r['tolerance_m']]
        cheaper = [r for r in fixed if r['cost_ms_per_s'] <= default['cost_ms_per_s']]
        best = min(cheaper, key=lambda r: r['hem_rms_m'])
        rows.append([clip, f'{default["cost_ms_per_s"]:.0f}',
                     f'{_mm(default["hem_rms_m"])} / {_mm(default["vs_gs"]["hem_rms_m"])}',
                     f'{"yes" if default.get("pareto") else "no"} / '
                     f'{"yes" if default.get("pareto_gs") else "no"}',
                     f'{best["label"]}: {_mm(best["hem_rms_m"])}',
                     f'{_mm(data["richardson"]["hem_rms_m"])}'])
    return [f'{len(fixed)} fixed methods per clip of {s["clip_seconds"]:g} s; default '
            f'{s["default"]}:', ''] + _table((
                'clip', 'default: CPU ms per simulated s', 'hem RMS vs XPBD / GS ref (mm)',
                'on the Pareto front (XPBD / GS ref)',
                'closest to the XPBD ref at no more cost: hem RMS (mm)',
                'XPBD ref\'s own uncertainty (mm)'), rows)


def stress_matrix(sources: Sequence[Any]) -> list[str]:
    """Return how each scene ended per method, with the worst figures behind it.

    :param sources: stress.json.
    """
    runs = sources[0]
    methods = list(dict.fromkeys(r['method'] for r in runs))
    scenes = list(dict.fromkeys(r['scene'] for r in runs))
    cell = {(r['scene'], r['method']): r for r in runs}

    def said(r: dict) -> str:
        return (f'{r["verdict"]} ({r["max_vertical_stretch"] * 100:.1f} %, '
                f'{r["max_inside_m"] * 100:.1f} cm)')
    rows = [[scene] + [said(cell[scene, m]) for m in methods] for scene in scenes]
    # The legend in the corner: worst vertical stretch at any input, deepest inside a collider.
    return _table(['scene: how it ended (stretch %, inside cm)'] + methods, rows)


def _sessions(report: dict) -> list[dict]:
    return report['sessions'] if 'sessions' in report else [report]


def analyze_per_input(sources: Sequence[Any]) -> list[str]:
    """Return per session the worst and p99 of the per-input figures, from ``analyze``.

    :param sources: report.json files of ``jacket_cloth analyze``.
    """
    rows = []
    for report in sources:
        for r in _sessions(report):
            vs, hs, ins = r['vertical_stretch'], r['horizontal_stretch'], r['inside_m']
            rows.append([os.path.splitext(os.path.basename(r['file'].rstrip('/')))[0],
                         str(r['inputs']), f'{vs["max"] * 100:.2f} / {vs["p99"] * 100:.2f}',
                         f'{hs["max"] * 100:.1f} / {hs["p99"] * 100:.1f}',
                         f'{ins["max"] * 1e3:.0f} / {ins["p99"] * 1e3:.0f}',
                         _body_inside(r),
                         f'{r["resets"]} ({"; ".join(r["reset_reasons"])})'])
    return _table(('session', 'inputs', 'vertical stretch % max / p99',
                   'horizontal stretch % max / p99', 'inside mm max / p99',
                   'inside the body mm max / p99', 'resets'), rows)


def _body_inside(report: dict) -> str:
    """Return analyze's ``body_inside_m`` as max / p99 in mm (a report from before it: n/a)."""
    body = report.get('body_inside_m')
    return 'n/a' if body is None else f'{body["max"] * 1e3:.1f} / {body["p99"] * 1e3:.1f}'


SPEED = 'bench_speed/speed.json'
SPEED_RUN = f'{PROG} bench speed --endurance 3600 --out out/bench_speed'
BENCH = ('bench/bench.json',), (f'{PROG} bench --out out/bench',)
LOD_RUN = f'{PROG} bench lod --out out/bench_lod'
TABLES: dict[str, Table] = {
    'speed.latest': Table((SPEED,), (SPEED_RUN,), speed_latest),
    'speed.profile': Table((SPEED,), (SPEED_RUN,), speed_profile),
    'speed.host': Table((SPEED,), (SPEED_RUN,), speed_host),
    'lod.latest': Table(('bench_lod/lod.json',), (LOD_RUN,), lod_latest),
    'crowd.lod': Table(('bench_lod/crowd_lod.json',), (LOD_RUN,), crowd_lod),
    'crowd.held': Table((SPEED,), (SPEED_RUN,), crowd_held),
    'bench.pareto': Table(*BENCH, bench_pareto),
    'bench.references': Table(*BENCH, bench_references),
    'stress.matrix': Table(('stress/stress.json',), (f'{PROG} stress --out out/stress',),
                           stress_matrix),
    'analyze.clips': Table(('clips/report.json', 'real/report.json'), (
        'jacket_cloth analyze idle.mcap walk.mcap ... showcase.mcap --compare --out out/clips',
        'jacket_cloth analyze mb_jacket.mcap fb_jacket.mcap --compare --out out/real'),
        analyze_per_input),
    'analyze.deepmimic': Table(('deepmimic/report.json', 'spinkick/report.json'), (
        'jacket_cloth analyze walk.mcap ... dance_a.mcap --compare --urdf humanoid.urdf --rig '
        'rig.yaml --out out/deepmimic',
        'jacket_cloth analyze spinkick.mcap --urdf humanoid.urdf --rig rig.yaml '
        '--out out/spinkick'), analyze_per_input),
}


# -- regions -------------------------------------------------------------------------------------

def rendered(kind: str, results: str) -> str | None:
    """Return a region's new body from the results, or None if they are not all there.

    :param kind: a key of :data:`TABLES`.
    :param results: the folder the benches wrote under (``out``).
    :raises Missing: the results lack a part the table needs.
    """
    table = TABLES[kind]
    paths = [os.path.join(results, s) for s in table.sources]
    if not all(os.path.isfile(p) for p in paths):
        return None
    loaded = []
    for path in paths:
        with open(path, encoding='utf-8') as f:
            loaded.append(json.load(f))
    runs = '; '.join(f'`{c}`, run {d}' for c, d in dict.fromkeys(
        run_of(p, c) for p, c in zip(paths, table.commands)))
    try:
        lines = table.render(loaded)
    except (KeyError, IndexError, TypeError) as e:
        raise Missing(f'results of another shape ({type(e).__name__}: {e})') from None
    # A line of text right after a table would be read as one more row of it.
    return f'From {runs}:\n\n' + '\n'.join(lines) + '\n\n'


def rewrite(text: str, results: str, say: Callable[[str], None]) -> str:
    """Return a document with each of its regions rendered anew where the results are there.

    :param text: the document.
    :param results: the folder the benches wrote under.
    :param say: called with a line for each region kept as it was, and why.
    """
    def one(match: re.Match) -> str:
        kind = match['kind']
        if kind not in TABLES:
            raise ValueError(f'unknown table {kind!r} (tables: {", ".join(TABLES)})')
        try:
            body = rendered(kind, results)
        except Missing as e:
            say(f'{kind}: kept, the results lack it ({e})')
            return match[0]
        if body is None:
            say(f'{kind}: kept; run {" and ".join(TABLES[kind].commands)}')
            return match[0]
        return match[1] + body + match[4]
    return REGION.sub(one, text)


def regions(text: str) -> list[tuple[str, str]]:
    """Return (kind, body) of each marked region of a document, in order.

    :param text: the document.
    """
    return [(m['kind'], m['body']) for m in REGION.finditer(text)]


def run_tables(docs: str, results: str, check: bool) -> int:
    """Rewrite every marked region of the documents in a folder; say what changed.

    :param docs: the folder of markdown documents.
    :param results: the folder the benches wrote under.
    :param check: whether only to say what would change.
    :returns: 1 if checking and a region would change, else 0.
    """
    changed = []
    for name in sorted(os.listdir(docs)):
        if not name.endswith('.md'):
            continue
        path = os.path.join(docs, name)
        with open(path, encoding='utf-8') as f:
            text = f.read()
        new = rewrite(text, results, lambda line: print(f'{name}: {line}'))
        if new == text:
            continue
        changed.append(name)
        if not check:
            with open(path, 'w', encoding='utf-8') as f:
                f.write(new)
    verb = 'would change' if check else 'rewritten'
    print(f'{verb}: {", ".join(changed)}' if changed else 'every region is up to date')
    return 1 if check and changed else 0


def add_parser(sub: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add the ``tables`` command to the lab's command line.

    :param sub: the lab's subcommands.
    :returns: the command's parser.
    """
    t = sub.add_parser('tables', help='rewrite the docs\' figure tables from the lab\'s results')
    t.add_argument('--from', dest='results', default='out',
                   help='the folder the benches wrote under (default: out)')
    t.add_argument('--docs', default=os.path.join(os.path.dirname(__file__), '..', 'docs'),
                   help='the folder of documents (default: this checkout\'s docs/)')
    t.add_argument('--check', action='store_true',
                   help='change nothing; exit 1 if a region would change')
    return t
