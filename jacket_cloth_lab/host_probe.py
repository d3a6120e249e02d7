# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What the shared host slows, and a probe that says when: part of ``bench speed``.

On this machine the kernel, its parts and the Python interpreter run at two speeds about
1.7x apart, in phases from milliseconds to seconds, with no CPU steal, while the C yardstick
nearly keeps its speed. :func:`phases` times the kernel between small C loops
(``host_probe.c``), round after round, and says which of them slow with it: a loop whose
branches only their history predicts does, one chain of dependent operations (the kind of
work that bounds the yardstick's step) does not. The first is the probe: a pass of the kernel
with the probe slow on either side (:func:`quiet`) is taken as run in the slow phase and left
out, so the kernel is compared with the yardstick on a quiet host, as issue 37 asks. The
probe only correlates with the kernel's phase: some passes left out were fast.
"""

import ctypes
import functools
import os
import shutil
import subprocess
import tempfile
import time
from typing import Callable

import numpy as np

SOURCE = os.path.join(os.path.dirname(__file__), 'host_probe.c')
LOOPS = {'patterned': 'branches only their history predicts',
         'dependent': 'one chain of integer operations',
         'divisions': 'one chain of divisions',
         'independent': 'eight independent multiply-add chains'}
# A probe reading this many times the run's lowest marks the slow phase.
SLOW_AT = 1.5


class HostProbe:
    """``host_probe.c`` built into a temporary folder and loaded into this process."""

    def __init__(self) -> None:
        self._tmp = tempfile.TemporaryDirectory()
        lib = os.path.join(self._tmp.name, 'host_probe.so')
        # -O2, no -march=native: the patterned branch stays a branch.
        subprocess.run(['cc', '-O2', '-shared', '-fPIC', '-o', lib, SOURCE], check=True)
        self._lib = ctypes.CDLL(lib)
        for name in LOOPS:
            getattr(self._lib, name).restype = ctypes.c_double

    def loop_ms(self, name: str) -> float:
        """Return one run of a loop of :data:`LOOPS`, ms.

        :param name: the loop.
        """
        return getattr(self._lib, name)()

    def read(self) -> float:
        """Return the probe: one run of the patterned loop, ms (about a millisecond)."""
        return self._lib.patterned()


def build_probe() -> HostProbe | None:
    """Return the probe built here, or None where no C compiler is found or it fails."""
    if not shutil.which('cc'):
        return None
    try:
        return HostProbe()
    except (subprocess.CalledProcessError, OSError):
        return None


def quiet(pair: tuple[float, float], lowest: float) -> bool:
    """Tell whether the host was quiet on both sides of a timed pass.

    :param pair: the probe before and after the pass (:meth:`HostProbe.read`), ms.
    :param lowest: the lowest reading to judge by, ms.
    :returns: whether both readings are under :data:`SLOW_AT` times ``lowest``.
    """
    if not lowest > 0.0:
        raise ValueError(f'the host probe read {lowest} ms: no clock to judge by')
    return max(pair) < SLOW_AT * lowest


def python_loop_ms(n: int = 20000) -> float:
    """Return the time of a plain Python loop of ``n`` additions, ms.

    :param n: how many additions.
    """
    started = time.perf_counter_ns()
    total = 0
    for k in range(n):
        total += k
    return (time.perf_counter_ns() - started) * 1e-6


def phases(probe: HostProbe, kernel_us: Callable[[], float], rounds: int = 300,
           pause_s: float = 0.03, yardstick_us: Callable[[], float] | None = None) -> dict:
    """Time the kernel, a Python loop and each C loop in turn, round after round, on one CPU.

    :param probe: the built probe.
    :param kernel_us: one kernel measurement (the median step of a few captured states), us.
    :param rounds: how many rounds.
    :param pause_s: the sleep between rounds, so that the rounds spread over the phases.
    :param yardstick_us: one measurement of the C yardstick's step at the kernel's grid, us
        (its process inherits the CPU); None: not measured.
    :returns: ``rounds``, and per measure (``kernel``, ``yardstick``, ``python``, each loop):
        ``median``, ``spread`` (90th over 10th percentile) and ``with_kernel`` (its
        correlation with the kernel over the rounds; None for a measure that never moved).
    """
    timed = {'kernel': kernel_us, 'yardstick': yardstick_us, 'python': python_loop_ms,
             **{name: functools.partial(probe.loop_ms, name) for name in LOOPS}}
    names = [name for name, measure in timed.items() if measure is not None]
    table = np.empty((rounds, len(names)))
    allowed = os.sched_getaffinity(0)
    os.sched_setaffinity(0, {min(allowed)})     # every measure on the one CPU
    try:
        for r in range(rounds):
            for k, name in enumerate(names):
                table[r, k] = timed[name]()
            time.sleep(pause_s)
    finally:
        os.sched_setaffinity(0, allowed)
    with np.errstate(invalid='ignore', divide='ignore'):     # a measure that never moved
        corr = np.corrcoef(table.T)[0]
    spread = np.percentile(table, 90, axis=0) / np.percentile(table, 10, axis=0)
    return {'rounds': rounds,
            'measures': {name: {'median': float(np.median(table[:, k])),
                                'spread': float(spread[k]),
                                'with_kernel': float(corr[k]) if np.isfinite(corr[k]) else None}
                         for k, name in enumerate(names)}}


def summary(result: dict) -> list[str]:
    """Return markdown lines: each measure's spread and how it follows the kernel.

    :param result: what :func:`phases` returned.
    """
    what = {'kernel': 'the cloth kernel, one step (us)',
            'yardstick': 'the C yardstick, one step at that grid (us)',
            'python': 'a plain Python loop (ms)', **{k: f'C: {v} (ms)' for k, v in LOOPS.items()}}
    lines = [f'What the host slows with the kernel ({result["rounds"]} rounds, each measure once '
             'per round, one CPU):', '',
             '| measure | median | 90th / 10th percentile | correlation with the kernel |',
             '|---|---|---|---|']
    for name, m in result['measures'].items():
        corr = 'n/a' if m['with_kernel'] is None else f'{m["with_kernel"]:.2f}'
        lines.append(f'| {what[name]} | {m["median"]:.2f} | {m["spread"]:.2f}x | {corr} |')
    return lines
