# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""The host probe of ``bench speed``: which passes count as timed on a quiet host.

The kernel's speed here follows phases of the shared host that the C yardstick does not
(jacket_cloth_lab/host_probe.py); the probe's readings decide which kernel passes count.
"""

import json
import shutil

import pytest

from jacket_cloth_lab import host_probe, speed
from jacket_cloth_lab.host_probe import LOOPS, phases, quiet, summary
from jacket_cloth_lab.speed import kernel as speed_kernel


def test_a_pass_is_quiet_only_with_both_readings_near_the_lowest():
    # Under 1.5 times the lowest reading on both sides counts; 1.5 or more on either side is
    # the slow phase.
    assert [quiet(pair, 1.0) for pair in [(1.0, 1.2), (1.2, 1.6), (1.6, 1.0), (1.49, 1.1)]] == [
        True, False, False, True]
    with pytest.raises(ValueError, match='read 0.0 ms'):
        quiet((0.0, 0.0), 0.0)


class _ScriptedHost:
    """A host whose phase is a function of the kernel pass, one phase per pass.

    The kernel pass takes 50 us quiet and 90 us slow; the probe after a pass reads 1 ms
    quiet and 2 ms slow (``readings`` overrides it); the yardstick always takes 100 us.
    """

    def __init__(self, slow_at, readings=None):
        self.slow_at, self.readings, self.passes = slow_at, readings, 0
        self.slow = slow_at(0)          # the phase the run begins in

    def kernel_step_ns(self, steps, repeat=1):
        self.slow = self.slow_at(self.passes)
        self.passes += 1
        return 90e3 if self.slow else 50e3

    def read(self):
        if self.readings:
            return self.readings(self.passes)
        return 2.0 if self.slow else 1.0

    def step_ns(self, cols, rows, iterations, steps=0):
        return {'step_ns_median': 100e3, 'constraints': 545}


def _cycle(i):
    return (False, False, True, True)[i % 4]       # quiet, quiet, slow, slow


def test_the_kernel_is_compared_with_the_yardstick_over_the_quiet_passes_only(monkeypatch):
    host = _ScriptedHost(_cycle)
    monkeypatch.setattr(speed_kernel, 'kernel_step_ns', host.kernel_step_ns)
    got = speed.in_rounds([()], host, 9, 12, 8, probe=host)
    # A quiet pass after a quiet one counts; each round runs until 20 count.
    rounds = speed.KERNEL_TARGET['rounds']
    assert got['quiet'] == [True] * rounds and got['counted'] == 'quiet rounds'
    assert got['quiet_passes'] == [speed.ROUND_REPEATS] * rounds
    assert got['kernel_ns'] == 50e3 and got['ratio'] == 0.5
    assert all(ns is not None and ns > 50e3 for ns in got['slow_kernel_ns'])
    assert json.loads(json.dumps(got)) == got
    # Without the probe every pass counts, the slow ones too.
    plain = speed.in_rounds([()], _ScriptedHost(_cycle), 9, 12, 8)
    assert 'quiet' not in plain and max(plain['ratios']) == 0.9
    assert plain['counted'] == 'every round'


def test_a_run_that_begins_in_the_slow_phase_judges_its_first_rounds_again(monkeypatch):
    # Slow for the first 30 passes: judged against the lowest reading so far (a slow one),
    # the first round counts slow passes; against the run's lowest it is not quiet, and a
    # round more is run in its place.
    host = _ScriptedHost(lambda i: i < 30 or _cycle(i))
    monkeypatch.setattr(speed_kernel, 'kernel_step_ns', host.kernel_step_ns)
    got = speed.in_rounds([()], host, 9, 12, 8, probe=host)
    assert got['quiet'][0] is False and sum(got['quiet']) == speed.KERNEL_TARGET['rounds']
    assert len(got['ratios']) > speed.KERNEL_TARGET['rounds']
    assert got['ratio'] == 0.5


def test_a_host_never_quiet_leaves_item_4_unmeasured(monkeypatch):
    # Every pass has a slow reading on one side: no pass counts, the run stops at its most
    # rounds, and item 4 is neither met nor missed.
    host = _ScriptedHost(lambda i: False, readings=lambda i: 2.0 if i % 2 else 1.0)
    monkeypatch.setattr(speed_kernel, 'kernel_step_ns', host.kernel_step_ns)
    got = speed.in_rounds([()], host, 9, 12, 8, probe=host)
    assert len(got['ratios']) == speed.MOST_ROUNDS and not any(got['quiet'])
    assert got['counted'] == 'every round'
    [target] = speed.targets({'kernel': [dict(got, grid='9x12', iterations=8)]})
    assert target['met'] is None and target['measured'].startswith('no round on a quiet host')


def test_item_4_says_how_many_passes_the_probe_found_quiet():
    row = {'grid': '9x12', 'iterations': 8, 'ratio': 0.6, 'ratios': [0.6, 0.9, 0.6, 0.6],
           'quiet': [True, False, True, True], 'passes': [40, 200, 30, 25],
           'quiet_passes': [20, 3, 20, 20], 'slow_kernel_ns': [80e3, 90e3, None, 85e3],
           'limit_rounds_ns': [100e3] * 4}
    [target] = speed.targets({'kernel': [row]})
    assert target['met'] is True
    assert 'median of 3 rounds timed on a quiet host (of 4)' in target['figure']
    assert ('63 of 295 passes with the probe quiet, the passes not counted 0.80–0.90x'
            in target['measured'])
    # Fewer quiet rounds than the target needs: not measured, whatever the ratio.
    row['quiet'] = [True, False, False, False]
    assert speed.targets({'kernel': [row]})[0]['met'] is None


class _ScriptedLoops:
    """Loops whose times follow a scripted kernel (patterned) or stay put (the others)."""

    def __init__(self):
        self.k = 0

    def kernel_us(self):
        self.k += 1
        return 80.0 if self.k % 3 == 0 else 47.0

    def loop_ms(self, name):
        return (2.5 if self.k % 3 == 0 else 1.0) if name == 'patterned' else 1.2


def test_phases_report_each_measures_spread_and_correlation_with_the_kernel():
    host = _ScriptedLoops()
    got = phases(host, host.kernel_us, rounds=30, pause_s=0.0)
    m = got['measures']
    assert set(m) == {'kernel', 'python', *LOOPS}
    assert m['patterned']['with_kernel'] == pytest.approx(1.0)
    assert m['dependent']['with_kernel'] is None        # it never moved: no correlation
    assert m['kernel']['spread'] == pytest.approx(80.0 / 47.0)
    assert any('branches only their history predicts' in line for line in summary(got))


@pytest.mark.skipif(shutil.which('cc') is None, reason='no C compiler (cc) to build the probe')
def test_the_probe_builds_and_times_each_loop():
    probe = host_probe.build_probe()
    assert probe.read() > 0.0
    assert all(probe.loop_ms(name) > 0.0 for name in LOOPS)
