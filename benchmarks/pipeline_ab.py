# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""Time one input through the node's pipeline with two source trees at once, one core each.

    python benchmarks/pipeline_ab.py OLD_TREE NEW_TREE [--rounds 6] [--seconds 20] [--crowd N]

Each round starts one process per tree at the same moment, each pinned to its own core (the
cores swapped every round), so both see the same host: on the shared machine the speed of one
process after another drifts by more than the difference between builds. Each process feeds a
60 Hz walk's bytes through a SessionPipeline (no recording) as the tree's replay takes them
(``on_raw`` where it has one, else its reader and ``on_joint_state``) three times and prints
its best median main-thread CPU per input; with ``--crowd N``, N characters (walk, run, idle,
dodge in turn) through one CrowdPipeline on one thread, each tick's inputs as one batch, and the
process's CPU per character-input. Both trees must have their kernels compiled.
"""

import argparse
import os
import statistics
import subprocess
import sys

_ONE_TREE = r'''
import statistics, time
from rclpy.serialization import serialize_message
from jacket_cloth_ros.core.fabric import load_fabrics
from jacket_cloth_ros.core.rig import load_rig
from jacket_cloth_ros.core.skeleton import load_shipped_character
from jacket_cloth_ros.motion.messages import clip_messages
from jacket_cloth_ros.ros.cdr import JointStateReader
from jacket_cloth_ros.ros.pipeline import CrowdPipeline, SessionPipeline, spread_phase
from jacket_cloth_ros.ros.values import default_values
skeleton = load_shipped_character()
rig, fabric = load_rig(skeleton), load_fabrics()['tweed_jacket']
clips = [[bytes(serialize_message(m))
          for _, m in clip_messages(skeleton, clip, 60.0, SECONDS, 10 ** 10)]
         for clip in (('walk', 'run', 'idle', 'dodge') if CROWD else ('walk',))]
best = []
for _ in range(3):
    spent = []
    if CROWD:
        crowd = CrowdPipeline(1)
        readers = [JointStateReader() for _ in range(CROWD)]
        for i in range(CROWD):
            crowd.add(SessionPipeline(skeleton, rig, default_values(fabric), timing=False,
                                      output_phase=spread_phase(i)))
        for k in range(len(clips[0])):
            started = time.process_time_ns()        # numba's thread pool included
            crowd.on_joint_states([(i, readers[i].read(clips[i % 4][k]))
                                   for i in range(CROWD)])
            spent.append((time.process_time_ns() - started) / CROWD)
    else:
        reader = JointStateReader()
        pipeline = SessionPipeline(skeleton, rig, default_values(fabric), timing=False)
        raw_way = getattr(pipeline, 'on_raw', None)     # as each tree's replay takes bytes
        for data in clips[0]:
            started = time.thread_time_ns()
            if raw_way:
                raw_way(data)
            else:
                msg = reader.read(data)
                pipeline.on_joint_state(msg, msg.stamp_ns)
            spent.append(time.thread_time_ns() - started)
    best.append(statistics.median(spent[60:]))      # past the first second's resets
print(min(best) * 1e-3)
'''


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('old')
    parser.add_argument('new')
    parser.add_argument('--rounds', type=int, default=6)
    parser.add_argument('--seconds', type=float, default=20.0)
    parser.add_argument('--crowd', type=int, default=0,
                        help='characters in one CrowdPipeline (0: one SessionPipeline)')
    args = parser.parse_args()
    code = _ONE_TREE.replace('SECONDS', repr(args.seconds)).replace('CROWD', str(args.crowd))
    ratios = []
    for k in range(args.rounds):
        procs = []
        for tree, core in ((args.old, k % 2), (args.new, 1 - k % 2)):
            env = dict(os.environ, PYTHONPATH=tree)
            procs.append(subprocess.Popen(['taskset', '-c', str(core), sys.executable, '-c',
                                           code], cwd=tree, env=env, stdout=subprocess.PIPE,
                                          stderr=subprocess.DEVNULL, text=True))
        old, new = (float(p.communicate()[0]) for p in procs)
        ratios.append(new / old)
        print(f'round {k + 1}: old {old:.1f} us, new {new:.1f} us a character-input, '
              f'new / old {new / old:.3f}')
    print(f'new / old: median {statistics.median(ratios):.3f} '
          f'({min(ratios):.3f}-{max(ratios):.3f}, {args.rounds} rounds)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
