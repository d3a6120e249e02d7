# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""``jacket_cloth_lab bench speed``: each cost as a ratio, measured in one run on this machine.

One module a part, run in this order by :mod:`.command`:

- host (``host``): what the shared host's slow phases slow (``lab.host_probe``);
- kernel (``kernel``): one cloth step of the shipped rig (``lab.bench.rig_at_grid``) against
  the compiled yardstick ``../shared/limit/cloth_ref.c`` at the same grid and iterations
  (built here when the file exists; the project never copies it);
- profile (``stages``): where one input's CPU goes, by stage, on the replay's and the node's
  path (``lab.profile``);
- markers (``markers``): what the jacket's markers add to the node's CPU per input;
- input (``per_input``): the node's pipeline per JointState (simulation, bones, /tf, markers,
  diagnostics) against the bare kernel's time for the steps that input triggers;
- replay (``replay``): simulated seconds per second of replay, for sessions of several lengths;
- endurance (``endurance``): simulated motion through the node's JointState callback with
  recording on, as fast as it runs: resident memory and step cost over time, every input with
  its output;
- node (``live``): the live node's CPU per JointState at 120 Hz with recording on, against the
  floor, a minimal rclpy node republishing a pre-built TFMessage of the same size and running
  one bare kernel step per message (``floor_node --kernel``); also against the stricter sum of
  that node without the kernel and the kernel's back-to-back median; the three run at once on
  one stream, so the host's drift reaches them alike; and its latency p99 (arrival to /tf)
  against one simulation step;
- start (``live``): process start to the first /tf, warm (compiled kernels cached) and cold;
- crowd (``lab.crowd``): the crowd node against one node process per character.

Each part also says how much CPU time the host gave to other guests while it ran (steal,
``measure``). ``targets`` judges the run against issue 37's targets, ``report`` writes
speed.json, speed.md and the charts.
"""

from .command import main, run
from .endurance import endurance
from .host import host_phases
from .kernel import (
    GRIDS, ITERATIONS, KERNEL_TARGET, LIMIT_SOURCE, MOST_PASSES, MOST_ROUNDS, ROUND_STEPS,
    Yardstick, in_rounds, kernel_vs_limit, limit_source, limit_steps)
from .live import cold_start, live_node, live_nodes, node_vs_floor, stop_processes
from .markers import LOWER_MARKERS_RATES, MARKERS_AT_MOST, markers_cost
from .measure import (
    RATE, ROUND_REPEATS, STEP_US, Steal, beside_kernel, captured_steps,
    kernel_step_ns)
from .per_input import input_vs_kernel
from .replay import replay_of_limit, replay_scaling
from .report import summary, write
from .stages import profiled
from .targets import COST_ONLY, NODE_OVER_FLOOR, REPLAY_TARGETS, targets

__all__ = [
    'COST_ONLY', 'GRIDS', 'ITERATIONS', 'KERNEL_TARGET', 'LIMIT_SOURCE', 'LOWER_MARKERS_RATES',
    'MARKERS_AT_MOST', 'MOST_PASSES', 'MOST_ROUNDS', 'NODE_OVER_FLOOR', 'RATE', 'REPLAY_TARGETS',
    'ROUND_REPEATS', 'ROUND_STEPS', 'STEP_US', 'Steal', 'Yardstick',
    'beside_kernel', 'captured_steps', 'cold_start', 'endurance', 'host_phases',
    'in_rounds', 'input_vs_kernel', 'kernel_step_ns', 'kernel_vs_limit', 'limit_source',
    'limit_steps', 'live_node', 'live_nodes', 'main', 'markers_cost', 'node_vs_floor',
    'profiled', 'replay_of_limit', 'replay_scaling', 'run', 'stop_processes', 'summary',
    'targets', 'write']
