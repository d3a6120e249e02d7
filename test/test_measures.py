# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The report names what it measures: stretch apart from compression, depth inside the body
apart from the push-out found during a step, each with where it is."""

import json

import numpy as np
import pytest

from jacket_cloth_ros.core.measures import depth_inside, edge_strain
from jacket_cloth_ros.core.simulation import Colliders


def test_stretch_and_compression_are_measured_apart():
    x = np.array([[0.0, 0, 0], [0, 0, -1.2], [0, 0, -1.7]])     # rest 1 and 1: +20 %, -50 %
    a, b, rest = np.array([0, 1]), np.array([1, 2]), np.array([1.0, 1.0])
    stretch, compression = edge_strain(x, a, b, rest)
    assert stretch.value == pytest.approx(0.2) and stretch.vertex == 1
    assert compression.value == pytest.approx(0.5) and compression.vertex == 2


def test_depth_inside_names_the_vertex_and_the_collider():
    none3 = np.zeros((0, 3))
    colliders = Colliders(np.array([[0.0, 0, 0]]), np.eye(3)[None], np.array([[0.2, 0.1, 0.1]]),
                          np.array([[1.0, 0, 0]]), np.array([[1.0, 0, 1]]), np.array([0.05]),
                          np.array([[0.0, 0, -1]]), np.array([[0.0, 0, 1]]))
    labels = ['torso', 'arm', 'floor']
    x = np.array([[0.15, 0, 0],          # 5 cm inside the ellipsoid along its long axis
                  [1.0, 0.02, 0.5],      # 3 cm inside the capsule
                  [0.0, 0, -1.01],       # 1 cm under the floor
                  [0.15, 0, 0]])         # as deep, but pinned: not counted
    free = np.array([True, True, True, False])
    worst = depth_inside(x, free, colliders, labels)
    assert worst.value == pytest.approx(0.05) and (worst.vertex, worst.collider) == (0, 'torso')
    x[0] = [0.3, 0, 0]
    worst = depth_inside(x, free, colliders, labels)
    assert worst.value == pytest.approx(0.03) and worst.collider == 'arm'
    x[1] = [3.0, 0, 0]
    assert depth_inside(x, free, colliders, labels).collider == 'floor'
    x[2] = [0.0, 0, -1.0]                # on the surface: not inside
    assert depth_inside(x, free, colliders, labels).vertex == -1
    none = Colliders(none3, np.zeros((0, 3, 3)), none3, none3, none3, np.zeros(0), none3, none3)
    assert depth_inside(x, free, none, []).value == 0.0


def test_analyze_reports_each_measure_as_max_and_p99_with_where(tmp_path):
    from jacket_cloth_ros.tools.cli import main
    from jacket_cloth_ros.tools.analyze import MEASURES
    clip = tmp_path / 'clip.mcap'
    assert main(['motion', '--clip', 'run', '--duration', '2', '-o', str(clip)]) == 0
    assert main(['analyze', str(clip), '--out', str(tmp_path / 'out')]) == 0
    report = json.loads((tmp_path / 'out' / 'report.json').read_text())
    for name in MEASURES:
        m = report[name]
        assert 0.0 <= m['p99'] <= m['max'] and 'at_s' in m, name
    assert report['horizontal_stretch']['max'] > 0.01             # the run widens the hem
    assert len(report['horizontal_stretch']['vertex']) == 2        # (row, column)
    assert report['vertical_stretch']['max'] <= 0.10               # M12, at every input
    assert report['push_out_m']['max'] > report['inside_m']['max']  # pushed out, not left in
    assert report['worst_instant'] == 'worst_instant.png'
    assert (tmp_path / 'out' / 'worst_instant.png').stat().st_size > 10_000
    summary = (tmp_path / 'out' / 'summary.md').read_text()
    assert 'vertical compression max / p99' in summary and 'inside a collider' in summary
    assert 'inside the body max / p99' in summary
    assert report['body_inside_m']['max'] == 0.0       # the shipped rig's colliders hold it
    from jacket_cloth_ros.tools.analyze import summary_line
    assert report['skipped_steps'] == 0 and 'skipped' not in summary_line(report)


def test_analyze_says_the_steps_a_slow_source_skipped(tmp_path, capsys):
    # Inputs at 2 Hz with a cap of 12 steps ran the cloth a fifth of the time, and analyze's
    # line, summary and report said nothing (a probe).
    from jacket_cloth_ros.tools.cli import main
    clip = tmp_path / 'slow.mcap'
    assert main(['motion', '--clip', 'walk', '--rate', '2', '--duration', '4', '-o',
                 str(clip)]) == 0
    capsys.readouterr()
    assert main(['analyze', str(clip), '--out', str(tmp_path / 'out')]) == 0
    report = json.loads((tmp_path / 'out' / 'report.json').read_text())
    assert report['skipped_steps'] == 8 * (60 - 12), report['skipped_steps']
    assert ', 384 steps skipped over max_steps_per_input (the cloth ran 20% of the time)' in \
        capsys.readouterr().out
    assert '| steps skipped (max_steps_per_input) | 384 |' in \
        (tmp_path / 'out' / 'summary.md').read_text()


def test_the_body_proxy_sees_what_the_rigs_colliders_do_not(tmp_path, capsys):
    # Issue 35 item 4: inside_m is measured against the rig's own colliders; a rig without
    # leg colliders gave 0 mm inside while the hem went through the thighs. body_inside_m
    # measures against every link's body (here the shipped character's bone capsules).
    import yaml
    from jacket_cloth_ros.core.config import shipped
    from jacket_cloth_ros.tools.cli import main
    with open(shipped('jacket_rig.yaml'), encoding='utf-8') as f:
        rig = yaml.safe_load(f)
    rig['colliders'] = [c for c in rig['colliders']
                        if c['name'] not in ('l_thigh', 'r_thigh', 'l_shin', 'r_shin')]
    (tmp_path / 'rig.yaml').write_text(yaml.safe_dump(rig))
    clip = tmp_path / 'clip.mcap'
    assert main(['motion', '--clip', 'run', '--duration', '2', '-o', str(clip)]) == 0
    capsys.readouterr()
    assert main(['analyze', str(clip), '--rig', str(tmp_path / 'rig.yaml'), '--out',
                 str(tmp_path / 'out')]) == 0
    report = json.loads((tmp_path / 'out' / 'report.json').read_text())
    assert report['inside_m']['max'] == 0.0
    body = report['body_inside_m']
    assert body['max'] > 0.02 and body['p99'] > 0.02 and body['link'] in ('l_thigh', 'r_thigh')
    assert body['vertex'][0] >= 8 and 'at_s' in body           # the hem's rows
    line = capsys.readouterr().out
    for figure in ('vertical stretch ', 'compression max ', 'horizontal stretch p99 ',
                   'inside 0.0 / 0.0 mm',
                   'inside the body ', 'non-finite 0', 'resets 1'):
        assert figure in line, figure


def test_worst_instants_at_one_moment_draw_one_frame_with_both_labels(monkeypatch):
    # The worst vertical stretch and the deepest vertex at one input: the picture labelled
    # both panels with the second, and the stretch was nowhere in it (a probe).
    from types import SimpleNamespace
    from jacket_cloth_ros.tools import analyze
    drawn = {}

    def draw(frames, skeleton, path, t0, labels, **kwargs):
        drawn.update(frames=frames, label=labels(frames[0].stamp_ns - t0))
    monkeypatch.setattr(analyze, 'draw_filmstrip', draw)
    frame = SimpleNamespace(stamp_ns=2_500_000_000)
    figures = SimpleNamespace(
        t0=0, worst_frames={'vertical_stretch': (0.397, frame), 'inside_m': (0.0146, frame)},
        report_where=lambda measure: {'vertical_stretch': 'r2 c5', 'inside_m': 'r1 c4 torso'}[
            measure])
    analyze._draw_worst(figures, None, 'worst.png', 'lying', None)
    assert drawn['frames'] == [frame]
    assert drawn['label'] == '\nworst vertical stretch 0.4\nr2 c5\nworst inside 0.015\nr1 c4 torso'
