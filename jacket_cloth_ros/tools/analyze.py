# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth analyze``: a session's figures, charts and filmstrip; several side by side.

The session's inputs run through the same pipeline as the live node (its recorded set-up, or
the options given), so every figure is the simulation's own, per input: strain, push-out depth,
M11 interventions, resets, wall time per step. When the file holds the node's /tf, every
re-simulated /tf is compared byte for byte with the recorded one (``replay_matches_recording``).
Sessions compared in one call are timed in the same process, so their step-time ratios hold.
"""

import json
import os
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..core.body_proxy import body_proxy, sleeved_links  # noqa: E402
from ..core.measures import (  # noqa: E402
    Worst, collider_labels, depth_inside, depth_under_floor)
from ..recording.reader import message_digest, message_digests  # noqa: E402
from ..ros.messages import outfit  # noqa: E402
from ..recording.writer import SESSION_CONFIG  # noqa: E402
from .picture import draw_filmstrip, sim_frame, view_axes_of  # noqa: E402
from .session import SessionInput, run_session  # noqa: E402

if TYPE_CHECKING:           # for the annotations only
    from ..core.simulation import StepReport
    from ..core.skeleton import Skeleton
    from ..ros.pipeline import SessionPipeline

# What a viewer sees wrong, per input on the published cloth (core.measures), and the push-out
# depth found during the steps: each reported as max and p99 over inputs, with where.
# ``body_inside_m``: inside the body proxy (core.body_proxy), not the rig's colliders.
MEASURES = ('vertical_stretch', 'vertical_compression', 'horizontal_stretch', 'inside_m',
            'push_out_m', 'body_inside_m', 'mesh_under_floor_m')

REPORTED_PARAMETERS = ('fabric_preset', 'sim_rate', 'stretch_limit', 'fabric.iterations',
                       'fabric.damping', 'fabric.world_share', 'wind', 'wind_gust')


class SessionFigures:
    """Per-input series of one session, gathered while it runs.

    :param session: the recording's input and set-up.
    :param moments: how many instants, evenly spread, the filmstrip shows.
    """

    def __init__(self, session: SessionInput, moments: int):
        self.session = session
        self.t0, t1 = session.stamp_range()
        self.targets = list(np.linspace(self.t0, t1, moments + 2)[1:-1].astype(np.int64))
        # The node's /tf (a file with its set-up), in the order it was published: the n-th
        # re-simulated /tf must equal the n-th recorded one (stamps can repeat after a reset).
        recording = session.recording
        self.recorded_tf = message_digests(recording.path, '/tf') \
            if SESSION_CONFIG in recording.metadata else []
        self.rows = []
        self.worst = {name: [] for name in MEASURES}        # (time s, Worst) per input
        self.labels = collider_labels(session.setup.rig)
        setup = session.setup
        self.body = body_proxy(setup.skeleton, sleeved_links(setup.rig))
        self.everywhere = np.ones(setup.rig.n, dtype=bool)
        # The jacket as the markers draw it, skinned on the bones: its vertices lie between
        # the simulated points, so the cloth may stand on the floor while the mesh dips under.
        self.outfit = outfit(setup.rig)
        corners = self.outfit.marker_corners()
        self.mesh = np.empty((corners, 3)), np.empty((corners, 4), dtype=np.float32)
        self.frames = []
        self.worst_frames = {}          # measure -> (value, frame) at its worst input so far
        self.reset_reasons = []
        self.tf_compared = 0
        self.tf_equal = 0
        self.nonfinite = 0
        self.skipped = 0            # steps over max_steps_per_input: time the cloth lost
        self.published = 0              # inputs whose bones went out
        self.tf_sent = 0                # /tf messages, as the node records them

    def probe(self, pipeline: 'SessionPipeline', report: 'StepReport', stamp: int,
              outputs: list[tuple[str, bytes]]) -> None:
        """Take the figures of the state after one input (``run_session``'s probe).

        :param pipeline: the session's pipeline, past the input.
        :param report: what the input did.
        :param stamp: the input's stamp, ns.
        :param outputs: the (key, CDR bytes) messages it gave.
        """
        sim = pipeline.sim
        if not report.accepted:
            return
        if report.reset:
            self.reset_reasons.append(report.reset)
        if report.merged:           # a second source's values: no step, no frame of its own
            return
        tf = [data for key, data in outputs if key == 'tf']
        # A non-finite cloth or bones reset the cloth (then /tf goes out); no /tf at all: both.
        self.nonfinite += report.reset.startswith('non-finite') or not tf
        self.skipped += report.skipped_steps
        self.published += bool(tf)
        for data in tf:             # with publish_world_tf, two per input: compare each
            if self.tf_sent < len(self.recorded_tf):
                self.tf_compared += 1
                self.tf_equal += self.recorded_tf[self.tf_sent] == message_digest(data)
            self.tf_sent += 1
        rig = sim.rig
        t = (stamp - self.t0) * 1e-9
        vs, vc, hs, hc = sim.edge_strains()
        vert, horiz = max(vs.value, vc.value), max(hs.value, hc.value)     # as sim.strain()
        inside = depth_inside(sim.x, rig.free, sim.collider_frames(sim.links), self.labels)
        body = depth_inside(sim.x, self.everywhere, self.body.posed(sim.links), self.body.labels)
        for name, worst in zip(MEASURES, (vs, vc, hs, inside,
                                          Worst(report.max_penetration, -1), body,
                                          self._mesh_under_floor(sim))):
            self.worst[name].append((t, worst))
        for name, worst in (('vertical_stretch', vs), ('inside_m', inside)):
            if name not in self.worst_frames or worst.value > self.worst_frames[name][0]:
                self.worst_frames[name] = (worst.value, sim_frame(sim, stamp))
        ref = sim.reference_points(sim.links, sim.layer)
        hem = slice((rig.rows - 1) * rig.cols, rig.n)
        anchor, rot = sim.hood_anchor(sim.links)
        d = sim.hood_p - anchor
        rest = rot @ rig.hood.rest_direction
        hood = np.degrees(np.arccos(np.clip(d @ rest / max(np.linalg.norm(d), 1e-12), -1, 1)))
        self.rows.append((
            (stamp - self.t0) * 1e-9, report.steps, report.max_penetration,
            report.limited_vertices, vert, horiz,
            report.step_cost_ns / report.steps * 1e-3 if report.steps else np.nan,
            float(np.linalg.norm(sim.x[hem] - ref[hem], axis=1).mean()), hood))
        while self.targets and stamp >= self.targets[0]:
            self.targets.pop(0)
            self.frames.append(sim_frame(sim, stamp))

    def report(self, pipeline: 'SessionPipeline') -> dict:
        """Return the session's report.json entry.

        :param pipeline: the session's pipeline, once it has run.
        """
        a = np.array(self.rows, dtype=float).reshape(-1, 9)
        step_us = a[:, 6][np.isfinite(a[:, 6])]
        values = pipeline.values.by_name()
        return {
            'file': os.path.abspath(self.session.recording.path),
            'complete': self.session.recording.complete,
            'topic': self.session.topic,
            'frames': self.published,
            'inputs': pipeline.inputs,
            'dropped_inputs': pipeline.dropped,
            'sim_steps': pipeline.sim.steps_total,
            'skipped_steps': self.skipped,
            'retried_steps': pipeline.sim.faults.retried,
            'duration_s': float(a[-1, 0]) if len(a) else 0.0,
            'max_vertical_strain': float(a[:, 4].max()) if len(a) else 0.0,
            'max_horizontal_strain': float(a[:, 5].max()) if len(a) else 0.0,
            'max_penetration_m': float(a[:, 2].max()) if len(a) else 0.0,
            'max_distance_exceeded': int(a[:, 3].sum()),
            'nonfinite_count': self.nonfinite,
            'rig_warnings': list(pipeline.sim.faults.rig),
            'collapsed': list(pipeline.sim.faults.collapse),
            'restless': list(pipeline.sim.faults.restless),
            'under_floor': list(pipeline.sim.faults.under_floor),
            'resets': len(self.reset_reasons),
            'reset_reasons': self.reset_reasons,
            'step_time_us': {
                'median': float(np.median(step_us)) if len(step_us) else None,
                'p99': float(np.percentile(step_us, 99)) if len(step_us) else None},
            'hem_offset_m': {'max': float(a[:, 7].max()) if len(a) else 0.0,
                             'mean': float(a[:, 7].mean()) if len(a) else 0.0},
            'hood_swing_deg': {'max': float(a[:, 8].max()) if len(a) else 0.0},
            'replay_matches_recording': self._matches() if self.tf_compared else None,
            'recorded_tf_compared': self.tf_compared,
            'parameters': {k: values[k] for k in REPORTED_PARAMETERS if k in values},
            **{name: self._measure(name, pipeline.sim.rig.cols) for name in MEASURES},
        }

    def report_where(self, name: str) -> str:
        """Say where a measure was worst: vertex (row, column) and collider, if known.

        :param name: a name of ``MEASURES``.
        """
        m = self._measure(name, self.session.setup.rig.cols)
        parts = ['r{} c{}'.format(*m['vertex'])] if 'vertex' in m else []
        return ' '.join(parts + [m[k] for k in ('collider', 'link') if k in m])

    def _mesh_under_floor(self, sim):
        """Return how deep the skinned jacket reaches under the rig's floor (0 without one).

        As an exported file's viewer skins it: the markers and pictures hold it out of the
        rig's planes (messages.jacket_planes), an export cannot.
        """
        floor = sim.rig.floor()
        if floor is None:
            return Worst(0.0, -1)
        points, colors = self.mesh
        self.outfit.draw_jacket(sim.links, sim.bones().poses, points, colors)
        return Worst(depth_under_floor(points, sim.root, floor), -1)

    def _measure(self, name, cols):
        """{max, p99} over inputs, and when (s), which vertex (row, column) and collider."""
        series = self.worst[name]
        if not series:
            return {'max': 0.0, 'p99': 0.0}
        values = np.array([w.value for _, w in series])
        k = int(np.argmax(values))
        t, worst = series[k]
        out = {'max': float(values[k]), 'p99': float(np.percentile(values, 99)), 'at_s': t}
        if worst.vertex >= 0:
            out['vertex'] = list(divmod(worst.vertex, cols))
        if worst.collider:
            out['link' if name == 'body_inside_m' else 'collider'] = worst.collider
        return out

    def _matches(self):
        """Every compared /tf equal, and as many as recorded unless the file was cut short."""
        counted = self.tf_sent == len(self.recorded_tf) or \
            not self.session.recording.complete
        return self.tf_equal == self.tf_compared and counted


def _series_chart(path, series, columns, title):
    """One panel per column; one line per session."""
    fig, axes = plt.subplots(len(columns), 1, figsize=(10, 2.2 * len(columns)), sharex=True,
                             squeeze=False)
    for ax, (col, label, scale) in zip(axes[:, 0], columns):
        for name, rows in series:
            ax.plot(rows[:, 0], rows[:, col] * scale, lw=1, label=name)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel('time in the session (s)')
    if len(series) > 1:
        axes[0, 0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


CHARTS = {
    'strain.png': ([(4, 'vertical strain', 1.0), (5, 'horizontal strain', 1.0)],
                   'worst relative stretch of the simulated stretch constraints, per input'),
    'penetration.png': ([(2, 'push-out depth (mm)', 1e3), (3, 'M11 vertices moved', 1.0)],
                        'deepest collider push-out and M11 interventions, per input'),
    'step_cost.png': ([(6, 'wall time per step (us)', 1.0)],
                      'simulation wall time per fixed step, measured while analysing'),
    'motion.png': ([(7, 'hem offset from skinned (cm)', 100.0), (8, 'hood swing (deg)', 1.0)],
                   'hem motion (mean distance from the skinned hem) and hood swing from rest'),
}


def output_names(count: int) -> list[str]:
    """Return the files ``analyze`` writes into its folder for ``count`` sessions.

    :param count: how many sessions.
    """
    strips = ['filmstrip.png'] if count == 1 else [f'filmstrip_{k}.png'
                                                   for k in range(1, count + 1)]
    worst = ['worst_instant.png'] if count == 1 else [f'worst_instant_{k}.png'
                                                      for k in range(1, count + 1)]
    return ['report.json', 'summary.md'] + sorted(CHARTS) + strips + worst


def analyze(sessions: list[SessionInput], out_dir: str, names: list[str] | None = None,
            moments: int = 6) -> dict:
    """Run each session, write report.json, summary.md, charts and filmstrip(s) to out_dir.

    :param sessions: the sessions, each a recording's input and set-up.
    :param out_dir: the output folder, made if missing.
    :param names: each session's name in the summary; None: its recording's file name.
    :param moments: how many instants each filmstrip shows.
    """
    os.makedirs(out_dir, exist_ok=True)
    names = names or [os.path.basename(s.recording.path.rstrip('/')) for s in sessions]
    reports, series = [], []
    for name, session in zip(names, sessions):
        figures = SessionFigures(session, moments)
        pipeline = run_session(session, probe=figures.probe)
        # The views' up is the world's (the rig's world_up), as the simulation's gravity;
        # forward, where the body faces at the first frame drawn.
        axes = view_axes_of(figures.frames or [f for _, f in figures.worst_frames.values()],
                            session.setup.rig)
        reports.append(figures.report(pipeline))
        series.append((name, np.array(figures.rows, dtype=float).reshape(-1, 9)))
        strip = 'filmstrip.png' if len(sessions) == 1 else f'filmstrip_{len(reports)}.png'
        if figures.frames:
            draw_filmstrip(figures.frames, session.setup.skeleton, os.path.join(out_dir, strip),
                           figures.t0, title=f'{name}: jacket (brown), hood (orange), jacket '
                           'bones (navy); dashed blue: skinned hem and hood',
                           world_axes=axes)
        reports[-1]['filmstrip'] = strip if figures.frames else None
        worst = 'worst_instant.png' if len(sessions) == 1 else \
            f'worst_instant_{len(reports)}.png'
        if figures.worst_frames:
            _draw_worst(figures, session.setup.skeleton, os.path.join(out_dir, worst), name, axes)
        reports[-1]['worst_instant'] = worst if figures.worst_frames else None
    for chart, (columns, title) in CHARTS.items():
        _series_chart(os.path.join(out_dir, chart), series, columns, title)
    if len(reports) == 1:
        report = dict(reports[0])
    else:
        base = reports[0]['step_time_us']['median']
        for r in reports:
            med = r['step_time_us']['median']
            r['step_time_vs_first'] = med / base if med and base else None
        report = {'sessions': reports}
    report['charts'] = sorted(CHARTS)
    with open(os.path.join(out_dir, 'report.json'), 'w', encoding='utf-8') as f:
        json.dump(report, f, indent=2)
    with open(os.path.join(out_dir, 'summary.md'), 'w', encoding='utf-8') as f:
        f.write(_summary(names, reports))
    return report


def _summary(names, reports):
    rows = [
        ('frames (/tf published)', lambda r: r['frames']),
        ('simulation steps', lambda r: r['sim_steps']),
        ('steps skipped (max_steps_per_input)', lambda r: r['skipped_steps']),
        ('duration (s)', lambda r: f"{r['duration_s']:.1f}"),
        ('max vertical strain', lambda r: f"{r['max_vertical_strain']:.4f}"),
        ('max horizontal strain', lambda r: f"{r['max_horizontal_strain']:.4f}"),
        ('vertical stretch max / p99', lambda r: _max_p99(r['vertical_stretch'], 1, '')),
        ('vertical compression max / p99', lambda r: _max_p99(r['vertical_compression'], 1,
                                                              '')),
        ('horizontal stretch max / p99', lambda r: _max_p99(r['horizontal_stretch'], 1, '')),
        ('inside a collider max / p99 (mm)', lambda r: _max_p99(r['inside_m'], 1e3, '')),
        ('inside the body max / p99 (mm)', lambda r: _max_p99(r['body_inside_m'], 1e3, '')),
        ('exported jacket under the floor max / p99 (mm)',
         lambda r: _max_p99(r['mesh_under_floor_m'], 1e3, '')),
        ('push-out during a step max / p99 (mm)', lambda r: _max_p99(r['push_out_m'], 1e3,
                                                                     '')),
        ('M11 vertex-steps moved', lambda r: r['max_distance_exceeded']),
        ('non-finite', lambda r: r['nonfinite_count']),
        ('resets', lambda r: f"{r['resets']} ({'; '.join(r['reset_reasons'])})"),
        ('step time median / p99 (us)', lambda r: _pair(r['step_time_us'])),
        ('hem offset max (cm)', lambda r: f"{r['hem_offset_m']['max'] * 100:.1f}"),
        ('hood swing max (deg)', lambda r: f"{r['hood_swing_deg']['max']:.0f}"),
        ('replay matches recording', lambda r: r['replay_matches_recording']),
    ]
    lines = ['# Session analysis', '',
             '| | ' + ' | '.join(names) + ' |', '|---' * (len(names) + 1) + '|']
    for label, get in rows:
        lines.append(f'| {label} | ' + ' | '.join(str(get(r)) for r in reports) + ' |')
    lines += ['', 'Step times were measured in this run, one session after the other; '
              'compare them as ratios, not across runs.', '',
              'Charts: ' + ', '.join(f'[{c}]({c})' for c in sorted(CHARTS)) + '; filmstrip: '
              + ', '.join(f'[{r["filmstrip"]}]({r["filmstrip"]})' if r['filmstrip'] else 'none'
                          for r in reports), '']
    return '\n'.join(lines)


def summary_line(report: dict) -> str:
    """Return the one line the command prints.

    Per session: frames, strain and step time, or how many inputs were dropped when none was
    simulated.

    :param report: what ``analyze`` returned.
    """
    parts = []
    for r in report.get('sessions', [report]):
        text = f'{os.path.basename(r["file"])} {r["frames"]} frames'
        if r['dropped_inputs']:
            text += f' ({r["dropped_inputs"]} of {r["inputs"]} inputs dropped)'
        median = r['step_time_us']['median']
        if median is None:
            text += ', nothing simulated'
        else:
            text += f', {target_figures(r)}, step {median:.0f} us median'
        parts.append(text)
    return '; '.join(parts)


def target_figures(r: dict) -> str:
    """Return a session's figures that have targets (issue 19, issue 35), max / p99; and more.

    :param r: one session's report (report.json's, or one of its ``sessions``).
    """
    def pair(name, scale=1.0, digits=3):
        return f'{r[name]["max"] * scale:.{digits}f} / {r[name]["p99"] * scale:.{digits}f}'
    # No target holds the vertical compression, but an edge folded to nothing (rows on one
    # point, a pinched front edge) is a failure the line must not hide.
    return (f'vertical stretch {pair("vertical_stretch")}, compression max '
            f'{r["vertical_compression"]["max"]:.3f}, horizontal stretch p99 '
            f'{r["horizontal_stretch"]["p99"]:.3f}, inside {pair("inside_m", 1e3, 1)} mm, '
            f'inside the body {pair("body_inside_m", 1e3, 1)} mm, non-finite '
            f'{r["nonfinite_count"]}, resets {r["resets"]}'
            # The cloth on the floor, an export's skinned mesh under it: said over 1 mm.
            + (f', the exported jacket {r["mesh_under_floor_m"]["max"] * 1e3:.0f} mm under the '
               f'floor at {r["mesh_under_floor_m"]["at_s"]:.1f} s'
               if r.get('mesh_under_floor_m', {}).get('max', 0.0) > 1e-3 else '')
            + (f', {r["skipped_steps"]} steps skipped over max_steps_per_input (the cloth ran '
               f'{r["sim_steps"] / (r["sim_steps"] + r["skipped_steps"]):.0%} of the time)'
               if r.get('skipped_steps') else ''))


def _pair(t):
    if t['median'] is None:
        return 'n/a'
    return f"{t['median']:.1f} / {t['p99']:.1f}"


def _max_p99(measure, scale, unit):
    """'max / p99' of a measure, with where the max was."""
    where = [f"{measure['at_s']:.2f} s"] if 'at_s' in measure else []
    if 'vertex' in measure:
        where.append('row {}, col {}'.format(*measure['vertex']))
    for key in ('collider', 'link'):
        if key in measure:
            where.append(measure[key])
    text = f"{measure['max'] * scale:.4g} / {measure['p99'] * scale:.4g}{unit}"
    return text + (f" ({', '.join(where)})" if where else '')


def _draw_worst(figures: SessionFigures, skeleton: 'Skeleton', path: str, name: str,
                axes: np.ndarray) -> None:
    """Draw the worst instants: the longest vertical edge, the deepest vertex in a collider.

    Side and front views at each of those inputs, the skinned pose dashed.
    """
    frames, labels = [], {}
    for measure, title in (('vertical_stretch', 'vertical stretch'), ('inside_m', 'inside')):
        value, frame = figures.worst_frames[measure]
        where = figures.report_where(measure)
        dt = frame.stamp_ns - figures.t0
        if dt not in labels:
            frames.append(frame)
        # Both worst at one instant: one frame with both labels, neither lost.
        labels[dt] = labels.get(dt, '') + f'\nworst {title} {value:.2g}\n{where}'
    draw_filmstrip(frames, skeleton, path, figures.t0, labels=lambda dt: labels.get(dt, ''),
                   title=f'{name}: the worst instants; dashed blue: skinned hem and hood',
                   world_axes=axes)
