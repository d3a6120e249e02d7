# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""`jacket_cloth bench speed --quick`: the figures exist, and nothing is lost on the way.

Speed targets are ratios printed by the benchmark, not asserted here (a shared machine is too
noisy for timed tests); what is asserted is what must hold on any machine.
"""

import json

from jacket_cloth_ros.lab.speed import _cpu_s, endurance
from jacket_cloth_ros.tools.cli import main


def test_bench_speed_quick_prints_ratios_and_charts(tmp_path, capsys):
    out = tmp_path / 'speed'
    assert main(['bench', 'speed', '--quick', '--out', str(out)]) == 0
    results = json.loads((out / 'speed.json').read_text())
    assert {r['grid'] for r in results['kernel']} == {'6x10', '9x12'}
    assert all(r['kernel_ns'] > 0 for r in results['kernel'])
    assert results['input']['ratio'] > 1.0          # the kernel is a part of an input
    assert [r['session_s'] for r in results['replay']] == [5.0, 10.0]
    assert all(r['realtime_x'] > 1.0 for r in results['replay'])
    assert (out / 'speed.png').stat().st_size > 10_000
    assert 'x the kernel' in capsys.readouterr().out


def test_endurance_keeps_every_input_and_memory_flat(skeleton, tmp_path):
    e = endurance(skeleton, 20.0, str(tmp_path), window_s=5.0)
    assert e['complete'] and e['inputs'] == 2400 and e['tf'] == e['inputs']
    rss = [w['rss_mb'] for w in e['windows']]
    assert rss[-1] - rss[1] < 5.0, rss              # after the first window's warm-up


def test_cpu_of_a_process_is_read_from_proc():
    import os
    busy = sum(i * i for i in range(200_000))
    assert busy > 0 and _cpu_s(os.getpid()) > 0
